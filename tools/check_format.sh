#!/usr/bin/env bash
# tools/check_format.sh — fails when a C, C++ or OpenCL source under host/, kernels/, tests/
# or tools/ differs from what clang-format makes of it with the checked-in .clang-format
# (ctest check_format). Fix with: tools/check_format.sh --fix
# clang-format 14 (Debian 12) is the reference: other major versions format differently,
# so with another one, or none, the check is skipped (exit 77).
set -euo pipefail
cd "$(dirname "$0")/.."
command -v clang-format >/dev/null || { echo "check_format: no clang-format (skipped)"; exit 77; }
major=$(clang-format --version | sed -n 's/.*version \([0-9]*\).*/\1/p')
[ "$major" = 14 ] || { echo "check_format: clang-format $major, not 14 (skipped)"; exit 77; }
mapfile -t files < <(find host kernels tests tools -type f \( -name '*.c' -o -name '*.h' -o -name '*.cpp' -o -name '*.cl' \) | sort)
if [ "${1:-}" = --fix ]; then
  clang-format -i "${files[@]}"
  exit 0
fi
if ! clang-format --dry-run --Werror "${files[@]}" 2> /tmp/check_format.$$; then
  grep -E '^[^ ].*(warning|error):' /tmp/check_format.$$ | sed 's/ \[-Wclang-format-violations\]//' | head -20
  n=$(grep -cE '(warning|error):' /tmp/check_format.$$ || true)
  rm -f /tmp/check_format.$$
  echo "check_format: $n place(s) differ from .clang-format; run tools/check_format.sh --fix" >&2
  exit 1
fi
rm -f /tmp/check_format.$$
echo "check_format: ${#files[@]} files formatted"
