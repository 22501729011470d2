#!/usr/bin/env bash
# Regenerates the validation report with the full suite:
#   1. build/photometria validate --report docs/validation
#      (docs/validation/validation.csv, validation_table.md, error_vs_time.png; needs gnuplot)
#   2. copies docs/validation/validation_table.md into docs/validation.md between the lines
#      <!-- table:begin --> and <!-- table:end --> (everything between them is replaced).
# Run after scripts/build.sh. `--table-only` skips step 1 (re-embeds the table of the last run).
# The "Highlights" prose in docs/validation.md is hand-written: check it against the new table.
set -euo pipefail
cd "$(dirname "$0")/.."

doc=docs/validation.md
table=docs/validation/validation_table.md
begin='<!-- table:begin -->'
end='<!-- table:end -->'

case "${1:-}" in
  "") build/photometria validate --report docs/validation ;;
  --table-only) ;;
  *) echo "usage: $0 [--table-only]" >&2; exit 1 ;;
esac

[ -s "$table" ] || { echo "$0: $table is missing or empty" >&2; exit 2; }
if [ "$(grep -cxF "$begin" "$doc")" != 1 ] || [ "$(grep -cxF "$end" "$doc")" != 1 ]; then
  echo "$0: $doc must hold exactly one '$begin' line and one '$end' line" >&2
  exit 1
fi

tmp="$doc.tmp-$$"
trap 'rm -f "$tmp"' EXIT
awk -v begin="$begin" -v end="$end" -v table="$table" '
  $0 == begin { print; while ((getline line < table) > 0) print line; skip = 1; next }
  $0 == end   { skip = 0 }
  !skip       { print }
' "$doc" > "$tmp"
mv "$tmp" "$doc"
trap - EXIT
echo "embedded $table in $doc"
