#!/usr/bin/env bash
# Installs Debian's `chromium` for tests/test_report.py's headless rendering test (CI: the Makefile's
# test target calls this when CI=true; in CI that test fails, rather than skips, without chromium).
# Needs root or passwordless sudo, and apt (Debian / Ubuntu images).
set -euo pipefail

if command -v chromium >/dev/null 2>&1; then
    echo "chromium already installed: $(chromium --version 2>/dev/null || echo unknown version)"
    exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    SUDO="sudo"
fi

export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
# fonts-liberation: the page's text renders with real glyphs in the screenshot.
$SUDO apt-get install -y -q chromium fonts-liberation
chromium --version
