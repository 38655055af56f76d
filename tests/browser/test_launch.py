"""Without a browser the browser tests fail, with the command that installs one."""

from __future__ import annotations

from pathlib import Path

import pytest
from playwright.sync_api import Playwright

from tests.support.browser_rig import launch


def test_a_missing_browser_fails_with_the_install_command(
    playwright: Playwright, tmp_path: Path
) -> None:
    with pytest.raises(pytest.fail.Exception, match=r"apt-get install -y chromium"):
        launch(playwright, tmp_path / "chromium")


def test_a_browser_that_does_not_start_fails_with_the_install_command(
    playwright: Playwright, tmp_path: Path
) -> None:
    broken = tmp_path / "chromium"
    broken.write_text("#!/bin/sh\nexit 1\n")
    broken.chmod(0o755)
    with pytest.raises(pytest.fail.Exception, match=r"did not start .*apt-get install"):
        launch(playwright, broken)
