#!/usr/bin/env bash
# Prints the path of a Python 3.13 interpreter for the Blender 5.2 LTS leg of `make test` (the
# `bpy` 5.2 wheel needs Python 3.13). Order: a working `python3.13` on the PATH; one built
# earlier into $BO2_PY313_PREFIX (default ~/.cache/bo2/python3.13); else CPython 3.13 is built
# there from Debian's python3.13 source package (about 6 minutes on 2 cores; needs root for apt
# and a Debian mirror in apt's sources). Exit status 2: none can be had on this machine.
#
#   PY313=$(tools/python313.sh) && "$PY313" -m venv .venv52
set -euo pipefail
prefix=${BO2_PY313_PREFIX:-${XDG_CACHE_HOME:-$HOME/.cache}/bo2/python3.13}
works() { "$1" -c 'import sys, ssl, sqlite3, lzma, bz2, zlib, ctypes; assert sys.version_info[:2] == (3, 13)' >/dev/null 2>&1; }

if command -v python3.13 >/dev/null && works "$(command -v python3.13)"; then
  command -v python3.13; exit 0
fi
if [ -x "$prefix/bin/python3.13" ] && works "$prefix/bin/python3.13"; then
  echo "$prefix/bin/python3.13"; exit 0
fi
[ "$(id -u)" -eq 0 ] || { echo "python313: no Python 3.13, and building one needs root" >&2; exit 2; }
# shellcheck source=tools/debian_mirror.sh
. "$(dirname "$0")/debian_mirror.sh"
mirror=$(debian_mirror)
[ -n "$mirror" ] || { echo "python313: no Debian mirror in apt's sources" >&2; exit 2; }

grep -qs '^ID=debian' /etc/os-release || { echo "python313: building one needs Debian's sources (not Debian here)" >&2; exit 2; }

work=$(mktemp -d)
# Debian 13 (trixie) ships CPython 3.13: its source package, from this machine's mirror, through
# an apt source that is removed again when the script ends
sources=/etc/apt/sources.list.d/bo2-python313-src.sources
trap 'rm -f "$sources"' EXIT
set +e  # a subshell with its own set -e, not in a || list (which would switch -e off)
(
  set -e
  printf 'Types: deb-src\nURIs: %s\nSuites: trixie\nComponents: main\nSigned-By: /usr/share/keyrings/debian-archive-keyring.gpg\n' \
    "$mirror" > "$sources"
  apt-get update -qq
  apt-get install -y -qq build-essential libssl-dev zlib1g-dev libbz2-dev liblzma-dev \
    libsqlite3-dev libffi-dev libreadline-dev libncurses-dev uuid-dev
  cd "$work"
  apt-get source --download-only python3.13
  tar xf python3.13_*.orig.tar.xz
  cd Python-3.13.*/
  ./configure --prefix="$prefix" --with-ensurepip=install
  make -j"$(nproc)"
  make install
) >"$work/build.log" 2>&1
status=$?
set -e
[ "$status" -eq 0 ] || { echo "python313: building CPython 3.13 failed:" >&2; tail -5 "$work/build.log" >&2; exit 1; }
rm -rf "$work"
works "$prefix/bin/python3.13" || { echo "python313: the built interpreter does not work" >&2; exit 1; }
echo "$prefix/bin/python3.13"
