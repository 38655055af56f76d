"""deploy/prometheus and deploy/grafana: checked by promtool, and every query names a metric
that the gateway exports (its /metrics on the simulated loop) or Prometheus's own ``up``."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.support.sim_app import running_app

DEPLOY = Path(__file__).resolve().parents[2] / "deploy"
PROMETHEUS = DEPLOY / "prometheus"
DASHBOARD = DEPLOY / "grafana" / "rc233-cell.json"
#: PromQL words that are not metric names
_PROMQL = {
    "sum", "by", "rate", "increase", "histogram_quantile", "absent", "or", "unless", "and",
    "on", "le", "loop", "instance", "job", "up", "max", "min", "without", "group_left",
    "deriv", "time",
}  # fmt: skip


def _promtool(*args: str) -> str:
    tool = shutil.which("promtool")
    if tool is None:
        pytest.fail("promtool is not installed: apt-get install -y prometheus (make test does)")
    done = subprocess.run([tool, *args], cwd=PROMETHEUS, capture_output=True, text=True,
                          timeout=60, check=False)  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def test_the_scrape_configuration_is_valid() -> None:
    _promtool("check", "config", "prometheus.yml")


def test_the_alert_rules_pass_their_promtool_cases() -> None:
    _promtool("check", "rules", "rc233-alerts.yml")
    out = _promtool("test", "rules", "rc233-alerts.test.yml")
    assert "SUCCESS" in out
    tested = set(
        re.findall(r"alertname: (\w+)", (PROMETHEUS / "rc233-alerts.test.yml").read_text())
    )
    rules = set(re.findall(r"alert: (\w+)", (PROMETHEUS / "rc233-alerts.yml").read_text()))
    assert rules == tested == {"RC233GatewayAbsent", "RC233LoopDown", "RC233ControllerOffline",
                               "RC233StaleData", "RC233ErrorLatched",
                               "RC233AdapterSlow", "RC233MemoryGrowing",
                               "RC233LineWorkerDown", "RC233LineWorkerRestarting"}  # fmt: skip


def _names(expr: str) -> set[str]:
    """The metric names in a PromQL expression (labels and strings taken out)."""
    expr = re.sub(r'"[^"]*"', "", expr)
    expr = re.sub(r"\{[^}]*\}", "", expr)
    expr = re.sub(r"\[[^\]]*\]", "", expr)
    expr = re.sub(r"\([^()]*?\bby\b\s*\([^)]*\)", "(", expr)
    expr = re.sub(r"\b(by|without|on)\s*\([^)]*\)", "", expr)
    words = set(re.findall(r"\b[a-zA-Z_:][a-zA-Z0-9_:]*\b", expr))
    return {w for w in words if w not in _PROMQL}


def _exported(text: str) -> set[str]:
    names = set(re.findall(r"^# TYPE (\S+) histogram", text, re.M))
    names = {f"{n}_{s}" for n in names for s in ("bucket", "sum", "count")}
    return names | set(re.findall(r"^# TYPE (\S+) ", text, re.M))


async def test_every_dashboard_and_alert_query_names_an_exported_metric() -> None:
    dashboard = json.loads(DASHBOARD.read_text())  # valid JSON
    assert dashboard["uid"] and dashboard["panels"]
    exprs = [t["expr"] for p in dashboard["panels"] for t in p["targets"]]
    exprs += re.findall(r"expr: (.+)", (PROMETHEUS / "rc233-alerts.yml").read_text())
    async with running_app() as api:
        text = (await api.client.get("http://localhost/metrics")).text
    exported = _exported(text)
    used = set().union(*(_names(e) for e in exprs))
    assert used, exprs
    assert used <= exported, f"not exported: {sorted(used - exported)}"
    ids = [p["id"] for p in dashboard["panels"]]
    assert len(set(ids)) == len(ids)
