"""Screenshot a benchmark report (``report.html``) in a headless browser.

    python scripts/screenshot_report.py DIR/report.html OUT.png [--width 1400] [--height 2600]

Uses Chromium's own headless mode (``chromium --headless=new --screenshot``); no Python
browser package is needed. Chromium is not a dependency of contour_env: install it with the
system's package manager (Debian: ``apt-get install chromium``) or point ``--browser`` at any
Chromium or Chrome binary. The picture is what a reader of the HTML report sees at that
window size (the top ``--height`` pixels of the page); it is written atomically.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome")


def find_browser(explicit: str | None) -> str:
    if explicit:
        path = shutil.which(explicit) or (explicit if Path(explicit).is_file() else None)
        if path is None:
            raise ValueError(f"--browser: {explicit}: not found")
        return path
    for name in BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    raise ValueError(
        f"no Chromium or Chrome found on PATH (tried {', '.join(BROWSERS)}); install one "
        "(Debian: apt-get install chromium) or give --browser PATH"
    )


def screenshot(html: Path, out: Path, width: int, height: int, browser: str) -> None:
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(suffix=".png", dir=out.parent)
    os.close(fd)
    try:
        cmd = [
            browser,
            "--headless=new",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            f"--window-size={width},{height}",
            f"--screenshot={tmp}",
            html.resolve().as_uri(),
        ]
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
        if res.returncode != 0 or Path(tmp).stat().st_size == 0:
            tail = (res.stderr or "").strip().splitlines()[-1:] or ["no output"]
            raise RuntimeError(f"{Path(browser).name} exited {res.returncode}: {tail[0]}")
        os.chmod(tmp, 0o644)
        os.replace(tmp, out)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("html", help="the report.html of `contour-env benchmark --out DIR`")
    ap.add_argument("out", help="PNG to write")
    ap.add_argument("--width", type=int, default=1400, help="window width, px (default 1400)")
    ap.add_argument("--height", type=int, default=2600, help="window height, px (default 2600)")
    ap.add_argument("--browser", help="Chromium/Chrome binary (default: the first on PATH)")
    args = ap.parse_args(argv)
    try:
        html = Path(args.html)
        if not html.is_file():
            raise ValueError(f"html: {html}: no such file")
        for name in ("width", "height"):
            if not 100 <= getattr(args, name) <= 20000:
                raise ValueError(f"--{name}: between 100 and 20000 px, got {getattr(args, name)}")
        screenshot(html, Path(args.out), args.width, args.height, find_browser(args.browser))
    except (ValueError, RuntimeError, subprocess.TimeoutExpired) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
