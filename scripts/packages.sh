# Sourced by the setup, sanitizer and fuzz scripts: installs the Debian packages that are
# missing (with sudo when not root), nothing when all are there.
ensure_packages() {
  local missing=() p
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  ((${#missing[@]})) || return 0
  echo "installing ${missing[*]}"
  local sudo_cmd=()
  [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -q
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends \
    "${missing[@]}"
}

# The commit the format and clang-tidy checks compare with: STOREY_CHECK_BASE, else the
# merge base with main (or origin/main); on main itself, where that is HEAD, the commit
# before HEAD, so a clean checkout of main checks what its newest commit changed. Empty
# when there is none (a shallow clone): the caller skips its check.
check_base() {
  if [ -n "${STOREY_CHECK_BASE:-}" ]; then
    echo "$STOREY_CHECK_BASE"
    return
  fi
  local ref base=""
  for ref in main origin/main; do
    if git rev-parse --verify -q "$ref^{commit}" >/dev/null; then
      base=$(git merge-base HEAD "$ref")
      break
    fi
  done
  if [ -z "$base" ] || [ "$base" = "$(git rev-parse HEAD)" ]; then
    base=$(git rev-parse --verify -q "HEAD~1^{commit}" || true)
  fi
  echo "$base"
}
