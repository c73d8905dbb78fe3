#!/usr/bin/env bash
# Prints the path of a Chromium for the review page's browser tests: $BO2_CHROMIUM, a chromium
# on PATH, else Debian's package installed with apt (needs root and a Debian mirror). Exit
# status 2: none can be had here, with the reason on stderr.
set -euo pipefail
for c in "${BO2_CHROMIUM:-}" "$(command -v chromium || true)" "$(command -v chromium-browser || true)"; do
  if [ -n "$c" ] && [ -x "$c" ]; then echo "$c"; exit 0; fi
done
[ "$(id -u)" -eq 0 ] || { echo "chromium: not installed, and installing it needs root" >&2; exit 2; }
command -v apt-get >/dev/null || { echo "chromium: not installed, and there is no apt-get" >&2; exit 2; }
log=$(mktemp)
if ! { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium; } >"$log" 2>&1; then
  echo "chromium: apt-get could not install it: $(tail -n 1 "$log")" >&2; rm -f "$log"; exit 2
fi
rm -f "$log"
command -v chromium || { echo "chromium: installed, but not on PATH" >&2; exit 2; }
