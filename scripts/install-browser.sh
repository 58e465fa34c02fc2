#!/usr/bin/env bash
# Installs the headless browser the HTML view's tests drive (tests/validator/test_view_browser.py):
# Debian's chromium and chromium-driver, through apt. Playwright's own browser download is not
# used: CI machines may not reach it, and the OS's packages get security updates.
# Skips (exit 0) where the browser is already there, apt is missing, or we are not root: the
# tests then skip with the reason.
set -uo pipefail

if command -v chromedriver >/dev/null && { command -v chromium >/dev/null \
        || command -v chromium-browser >/dev/null || command -v google-chrome >/dev/null; }; then
    echo "install-browser: a Chromium and chromedriver are installed"
    exit 0
fi
if ! command -v apt-get >/dev/null; then
    echo "install-browser: no apt-get here: the browser tests will skip"
    exit 0
fi
if [ "$(id -u)" -ne 0 ]; then
    echo "install-browser: not root, cannot apt-get install: the browser tests will skip"
    exit 0
fi
export DEBIAN_FRONTEND=noninteractive
if apt-get update -qq && apt-get install -y -qq --no-install-recommends chromium chromium-driver fonts-liberation \
        >/dev/null; then
    echo "install-browser: installed $(chromium --version 2>/dev/null)"
else
    echo "install-browser: apt-get could not install chromium: the browser tests will skip"
fi
exit 0
