"""scripts/screenshot_report.py: clear errors without a browser or a report; a real picture with
Chromium when the machine has one."""

from __future__ import annotations

import shutil

import pytest


@pytest.fixture
def screenshot_report(load_script):
    return load_script("screenshot_report")


def test_missing_report_is_a_one_line_error(tmp_path, capsys, screenshot_report):
    rc = screenshot_report.main([str(tmp_path / "nope.html"), str(tmp_path / "x.png")])
    assert rc == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: html:") and "\n" not in err
    assert not (tmp_path / "x.png").exists()


def test_unknown_browser_and_bad_size_are_named(tmp_path, capsys, screenshot_report):
    html = tmp_path / "r.html"
    html.write_text("<html><body>x</body></html>")
    mod = screenshot_report
    assert mod.main([str(html), str(tmp_path / "x.png"), "--browser", "no-such-browser-xyz"]) == 2
    assert "--browser: no-such-browser-xyz: not found" in capsys.readouterr().err
    assert mod.main([str(html), str(tmp_path / "x.png"), "--width", "5"]) == 2
    assert "--width: between 100 and 20000 px, got 5" in capsys.readouterr().err


def test_no_browser_on_path_says_how_to_get_one(monkeypatch, screenshot_report):
    mod = screenshot_report
    monkeypatch.setattr(mod.shutil, "which", lambda name: None)
    with pytest.raises(ValueError, match="apt-get install chromium"):
        mod.find_browser(None)


@pytest.mark.skipif(
    not any(shutil.which(b) for b in ("chromium", "chromium-browser", "google-chrome")),
    reason="no Chromium on this machine",
)
def test_screenshot_of_a_page_is_a_png_of_the_window_size(tmp_path, screenshot_report):
    html = tmp_path / "r.html"
    html.write_text("<html><body><h1>report</h1><table><tr><td>1</td></tr></table></body></html>")
    out = tmp_path / "shot.png"
    assert screenshot_report.main([str(html), str(out), "--width", "400", "--height", "300"]) == 0
    data = out.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    width = int.from_bytes(data[16:20], "big")
    height = int.from_bytes(data[20:24], "big")
    assert (width, height) == (400, 300)
