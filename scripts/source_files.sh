#!/bin/bash
# Sourced by the code checks (check_format.sh, check_code_size.sh): source_files PATTERN... prints
# the project's C++/CUDA files whose paths match one of the extended regular expressions, one per
# line. In a git checkout: the files git tracks; in a copy without .git (CI's deep copy, a release
# tarball): the same folders read from disk. third_party/ is never listed.
SOURCE_DIRS=(bench dypho_common dypho_mask dypho_mapping dypho_msgs dypho_pipeline dypho_tracking fuzz test tools)
source_files() {
  local pattern
  pattern="$(IFS='|'; echo "$*")"
  if [ "$(git -C "$ROOT" rev-parse --show-toplevel 2>/dev/null)" = "$ROOT" ]; then
    git -C "$ROOT" ls-files
  else
    (cd "$ROOT" && for d in "${SOURCE_DIRS[@]}"; do [ -d "$d" ] && find "$d" -type f; done)
  fi | grep -E "$pattern" | grep -v '^third_party/' | sort
}
