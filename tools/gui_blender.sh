#!/usr/bin/env bash
# Prints the path of a runner for a real, windowed Blender: Debian's Blender 5.2 LTS package
# (Python 3.14, numpy 2.4) in a Debian chroot, drawn by Xvfb with Mesa's software OpenGL, with
# nothing of the engine's installed: the extension's zip brings its own wheels. The
# runner takes Blender's own arguments and runs them in that window, in the current folder;
# the current folder and /tmp are the same paths inside. `make test-gui` drives it.
#
#   runner=$(tools/gui_blender.sh) && "$runner" --factory-startup --python tests/gui/walk.py
#
# Screenshots inside the window: `import -window root FILE.png` (ImageMagick; bpy's screenshot
# operator reads back black from Xvfb). Built once (debootstrap, then apt; about 5 minutes) into
# $BO2_GUI_ROOT (default ~/.cache/bo2/blender-gui) and reused. Needs root, debootstrap (installed
# with apt when missing) and a Debian mirror in apt's sources. Exit status 2: it cannot be built
# on this machine (not root, no mirror), with the reason on stderr.
set -euo pipefail
root=${BO2_GUI_ROOT:-${XDG_CACHE_HOME:-$HOME/.cache}/bo2/blender-gui}
runner="$root.run"
packages="blender python3-numpy python3-requests python3-cattr python3-attr xvfb xauth x11-utils imagemagick libgl1-mesa-dri"
apt_opts="-o Acquire::Check-Valid-Until=false -o Acquire::Retries=3"

if [ -x "$runner" ] && [ -x "$root/usr/bin/blender" ] && [ -f "$root/.bo2-gui-ready" ]; then
  echo "$runner"; exit 0
fi
[ "$(id -u)" -eq 0 ] || { echo "gui_blender: needs root (chroot, mounts)" >&2; exit 2; }
# shellcheck source=tools/debian_mirror.sh
. "$(dirname "$0")/debian_mirror.sh"
mirror=$(debian_mirror)
[ -n "$mirror" ] || { echo "gui_blender: no Debian mirror in apt's sources" >&2; exit 2; }

# The runner: the chroot's Blender under xvfb-run, with cwd and /tmp mounted at their paths in
# a private mount namespace (nothing stays mounted after it ends).
write_runner() {
  echo '#!/usr/bin/env bash'
  echo "# Debian's Blender 5.2 in an Xvfb window, in the current folder (tools/gui_blender.sh)."
  printf 'root=%q\n' "$root"
  cat <<'RUNNER'
export ROOT="$root" CWD="$PWD"
ARGS=$(printf '%q ' "$@"); export ARGS
exec unshare --mount --propagation private bash -ec '
  for d in "$CWD" /tmp; do mkdir -p "$ROOT$d"; mount --bind "$d" "$ROOT$d"; done
  mount -t proc proc "$ROOT/proc"; mount --bind /dev "$ROOT/dev"; mount --bind /dev/pts "$ROOT/dev/pts"
  exec chroot "$ROOT" env HOME=/root LIBGL_ALWAYS_SOFTWARE=1 CWD="$CWD" ARGS="$ARGS" \
    bash -c '\''cd "$CWD" && eval exec xvfb-run -a -s "\"-screen 0 1920x1080x24\"" blender $ARGS'\''
'
RUNNER
}

log=$(mktemp)
set +e  # a subshell with its own set -e, not in a || list (which would switch -e off)
(
  set -e
  command -v debootstrap >/dev/null || { apt-get update -qq && apt-get install -y -qq debootstrap; }
  if [ ! -x "$root/usr/bin/apt-get" ]; then
    rm -rf "$root"; mkdir -p "$root"
    debootstrap --variant=minbase --include=ca-certificates sid "$root" "$mirror"
  fi
  cp /etc/resolv.conf "$root/etc/" 2>/dev/null || true
  ROOT="$root" APT="$apt_opts" PKGS="$packages" unshare --mount --propagation private bash -ec '
    mount -t proc proc "$ROOT/proc"; mount --bind /dev "$ROOT/dev"; mount --bind /dev/pts "$ROOT/dev/pts"
    chroot "$ROOT" env DEBIAN_FRONTEND=noninteractive bash -ec \
      "apt-get $APT update -qq; apt-get $APT install -y -qq --no-install-recommends $PKGS"'
  touch "$root/.bo2-gui-ready"
  write_runner > "$runner"
  chmod +x "$runner"
) >"$log" 2>&1
status=$?
set -e
if [ "$status" -ne 0 ]; then
  rm -f "$runner"
  echo "gui_blender: building the windowed Blender failed:" >&2; tail -5 "$log" >&2; exit 1
fi
rm -f "$log"
echo "$runner"
