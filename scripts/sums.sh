# Sourced: update_sums DIR NAME rewrites NAME's line of DIR/SHA256SUMS when
# that file exists (a release's folder), so a program or a zip built again
# into dist/ never leaves a checksum that no longer holds. Whole or not at
# all (a temporary file renamed).
update_sums() {
  local dir=$1 name=$2
  [ -f "$dir/SHA256SUMS" ] || return 0
  (
    set -e
    cd "$dir"
    { grep -v "  $name\$" SHA256SUMS || true; sha256sum "$name"; } > SHA256SUMS.tmp
    mv SHA256SUMS.tmp SHA256SUMS
  )
  echo "updated $dir/SHA256SUMS for $name"
}
