# Sourced by tools/gui_blender.sh and tools/python313.sh: `debian_mirror` prints the Debian
# mirror that apt uses here (deb822 sources first, then sources.list), or nothing.
debian_mirror() {
  local mirror
  mirror=$(sed -n 's/^URIs: *\([^ ]*\).*/\1/p' /etc/apt/sources.list.d/*.sources 2>/dev/null \
    | grep -v security | head -1 || true)
  [ -n "$mirror" ] || mirror=$(sed -n 's/^deb \(\[[^]]*\] \)\?\([^ ]*\) .*/\2/p' \
    /etc/apt/sources.list 2>/dev/null | grep -v security | head -1 || true)
  echo "$mirror"
}
