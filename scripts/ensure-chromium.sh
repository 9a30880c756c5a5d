#!/usr/bin/env bash
# Make Debian's Chromium available for the HTML report's browser tests (tests/report/test_html.py).
# Installs it with apt-get only when /usr/bin/chromium is missing and we are root with apt-get;
# otherwise it warns and the browser tests skip with that reason. Never fails the build.
# (Playwright drives this system browser; `playwright install` is never run: it downloads its own.)
set -u
CHROMIUM="${MOCAPKIT_CHROMIUM:-/usr/bin/chromium}"
if [ -x "$CHROMIUM" ]; then
    exit 0
fi
if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
    echo "ensure-chromium: $CHROMIUM missing; installing Debian's chromium" >&2
    export DEBIAN_FRONTEND=noninteractive
    if { apt-get install -y -q chromium >/dev/null 2>&1 || { apt-get update -q >/dev/null 2>&1 && apt-get install -y -q chromium >/dev/null; }; } \
        && [ -x "$CHROMIUM" ]; then
        echo "ensure-chromium: installed $("$CHROMIUM" --version 2>/dev/null || echo chromium)" >&2
        exit 0
    fi
    echo "ensure-chromium: WARNING: apt-get could not install chromium; the browser tests will skip" >&2
else
    echo "ensure-chromium: WARNING: $CHROMIUM missing and apt-get is not usable as root; the browser tests will skip" >&2
fi
exit 0
