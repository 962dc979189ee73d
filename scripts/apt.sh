# Sourced by the other scripts: apt_install PACKAGE... installs the Debian
# packages that are not installed yet, quietly (log in a temp file, shown on
# failure), running apt-get update first. Installs nothing when all are there.
apt_install() {
  local missing=() package
  for package in "$@"; do
    dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" ||
      missing+=("$package")
  done
  ((${#missing[@]})) || return 0
  local sudo=()
  if [[ $EUID -ne 0 ]]; then
    command -v sudo >/dev/null || {
      echo "pano4d: need root (or sudo) to install: ${missing[*]}" >&2
      return 1
    }
    sudo=(sudo)
  fi
  local log start=$SECONDS
  log=$(mktemp -t pano4d-apt.XXXXXX.log)
  echo "pano4d: installing ${#missing[@]} Debian packages: ${missing[*]} (log: $log)"
  if ! { "${sudo[@]}" apt-get update -qq &&
         "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
           --no-install-recommends "${missing[@]}"; } >"$log" 2>&1; then
    tail -n 30 "$log" >&2
    echo "pano4d: apt-get failed; the full log is $log" >&2
    return 1
  fi
  echo "pano4d: packages installed in $((SECONDS - start)) s"
}
