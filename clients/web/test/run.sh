#!/usr/bin/env bash
# Browser test of the dashboard (ctest: clients_web). Installs playwright-core from the committed
# package-lock.json into clients/web/test/node_modules on first use (no browser download: it
# drives Debian's /usr/bin/chromium, which scripts/test installs), then runs dashboard.test.js.
# Usage: run.sh GEARLOOP_SERVER_BIN [OUTPUT_DIR [GEARLOOP_CLI_BIN]]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
server_bin="${1:?usage: run.sh GEARLOOP_SERVER_BIN [OUTPUT_DIR]}"
out_dir="${2:-${TMPDIR:-/tmp}/gearloop-web-test}"
for tool in node npm; do
  command -v "$tool" >/dev/null || { echo "run.sh: $tool not found (Node.js >= 20 is needed)"; exit 1; }
done
[ -x /usr/bin/chromium ] || { echo "run.sh: /usr/bin/chromium not found: run scripts/test, or apt-get install chromium"; exit 1; }
if [ ! -f "$here/node_modules/playwright-core/package.json" ] ||
   [ "$here/package-lock.json" -nt "$here/node_modules/.package-lock.json" ]; then
  # The browser is Debian's: never let an install step fetch one.
  PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --prefix "$here" --no-audit --no-fund --loglevel=error
fi
exec node "$here/dashboard.test.js" "$server_bin" "$out_dir" "${3:-}"
