#!/usr/bin/env bash
# The page's tests in real headless Chromium against the real `rigfit serve`: installs what they
# need on a fresh Debian machine (Chromium from Debian, the pinned npm packages of web/), builds
# the CLI if needed, then runs node's test runner over web/tests/. Called by scripts/test.sh.
set -euo pipefail
cd "$(dirname "$0")/.."

if [ ! -x /usr/bin/chromium ]; then
  echo "== installing chromium (Debian)"
  apt-get update -q
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium
fi
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  echo "== installing node and npm (Debian)"
  apt-get update -q
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q nodejs npm
fi

echo "== npm ci (web/)"
(cd web && npm ci --no-audit --no-fund --loglevel=error)

# Cargo rebuilds only what changed (the page is embedded in the binary).
echo "== cargo build -p rigfit-cli"
cargo build -p rigfit-cli --quiet

# The real assets (scripts/test-data.sh).
. scripts/test-data.sh

echo "== browser tests (screenshots in target/web-artifacts/)"
node --test --test-concurrency=1 web/tests/
