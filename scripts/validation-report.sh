#!/usr/bin/env bash
# Regenerates docs/validation/ (CSV, Markdown table, error-against-time plot) with the full suite.
# Run after scripts/build.sh; docs/validation.md embeds the results.
set -euo pipefail
cd "$(dirname "$0")/.."
build/photometria validate --report docs/validation
