# Root and apt-get helpers of scripts/setup.sh, in their own file so that a test can
# source them and call them with stand-in apt-get, dpkg and sudo on PATH
# (tests/test_setup_script.py): a test never installs real packages.

# as_root CMD...: runs CMD as root (directly when we are root, else through sudo).
as_root() {
  if [ "$(id -u)" -eq 0 ]; then
    "$@"
  elif command -v sudo >/dev/null 2>&1; then
    sudo "$@"
  else
    echo "error: '$*' needs root: run as root or install sudo" >&2
    return 1
  fi
}

# apt_install PKG...: installs the packages dpkg does not know yet, non-interactively.
# `env` carries the DEBIAN_FRONTEND assignment: with an empty sudo prefix a bare
# `VAR=value cmd` after an expansion would become the command word (issue 15 S1).
apt_install() {
  local missing=()
  for pkg in "$@"; do dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg"); done
  if [ "${#missing[@]}" -gt 0 ]; then
    echo "==> apt-get install ${missing[*]}"
    as_root env DEBIAN_FRONTEND=noninteractive apt-get update -qq || return
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" || return
  fi
}
