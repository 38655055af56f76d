"""Speed settings through the REST API: the manual's numbers (§7-1, §10 OH/OL/OS/OC/OX, §16).

Expected values are the manual's formulas worked by hand, not the code's: fH = OH x 300 / OX,
α = 1,474,560,000 / (OX x OS), tacc = |OH - OL| / (24,576 x (200 - OC)) x OS, and the S-curve
rule X = (OH - OL) / (2 x (200 - OC)) x OC <= 4,095, <= 16,383 - OH, <= 16,383 - OL.
"""

from __future__ import annotations

import pytest

from tests.support.sim_app import json_of, running_app

SETS = ("OH", "OL", "OS", "OC", "OX")


def sets(texts: list[str]) -> list[str]:
    """The speed-setting frames (a setting has digits after its mnemonic; queries do not)."""
    return [t for t in texts if t[:2] in SETS and t[2:].isdigit()]


async def test_defaults_of_section_16_and_their_derived_values() -> None:
    async with running_app() as api:
        mark = api.mark()
        speed = json_of(await api.client.get("/axes/x/speed"))
        # §16: OH 5000, OL 500, OS 300, OC 0, OX 300
        assert [speed[k] for k in ("oh", "ol", "os", "oc", "ox")] == [5000, 500, 300, 0, 300]
        assert speed["high_speed_pps"] == 5000.0  # 5000 x 300 / 300
        assert speed["low_speed_pps"] == 500.0
        assert speed["acceleration_pps2"] == 16384.0  # 1,474,560,000 / (300 x 300)
        # (5000 - 500) / (24,576 x 200) x 300 = 0.274658203125 s
        assert speed["acceleration_time_s"] == pytest.approx(0.274658203125)
        assert speed["s_curve_time_s"] == 0.0
        assert [t for t in api.heard("1", mark) if t in SETS] == ["OH", "OL", "OS", "OC", "OX"]


async def test_put_sends_the_settings_and_reads_them_back() -> None:
    async with running_app() as api:
        mark = api.mark()
        r = await api.client.put("/axes/x/speed", json={"oh": 4000, "os": 600})
        assert r.status_code == 200, r.text
        speed = json_of(r)
        assert (speed["oh"], speed["os"]) == (4000, 600)
        assert speed["acceleration_pps2"] == 8192.0  # 1,474,560,000 / (300 x 600)
        assert speed["high_speed_pps"] == 4000.0
        assert sets(api.heard("1", mark)) == ["OH4000", "OS600"]
        # per motor (§10 F list): y keeps the defaults
        other = json_of(await api.client.get("/axes/y/speed"))
        assert (other["oh"], other["os"]) == (5000, 300)


async def test_ox_is_shared_and_quantised() -> None:
    async with running_app() as api:
        await api.client.put("/axes/x/speed", json={"ox": 150})
        other = json_of(await api.client.get("/axes/y/speed"))
        assert other["ox"] == 150  # one OX for both motors (§10 OX)
        assert other["ox_internal"] == 148  # multiples of 4 (§7-1 table)
        assert other["high_speed_pps"] == pytest.approx(5000 * 300 / 148)


async def test_s_curve_rule_refused_before_sending() -> None:
    async with running_app() as api:
        mark = api.mark()
        # X = (9000 - 500) / (2 x 100) x 100 = 4,250 > 4,095
        r = await api.client.put("/axes/x/speed", json={"oh": 9000, "oc": 100})
        assert r.status_code == 422
        problem = json_of(r)
        assert problem["field"] == "body.oc"
        assert "4,095" in problem["rule"] and "§7-1" in problem["rule"]
        assert sets(api.heard("1", mark)) == []
        # X = (8690 - 500) / 200 x 100 = 4,095: allowed; OC last, once OH is in place
        r = await api.client.put("/axes/x/speed", json={"oh": 8690, "oc": 100})
        assert r.status_code == 200, r.text
        assert (json_of(r)["oh"], json_of(r)["oc"]) == (8690, 100)
        assert sets(api.heard("1", mark)) == ["OH8690", "OC100"]


async def test_changing_oh_under_an_s_curve_clears_oc_first() -> None:
    async with running_app() as api:
        assert (await api.client.put("/axes/x/speed", json={"oc": 50})).status_code == 200
        mark = api.mark()
        # Final X = (9000 - 500) / 300 x 50 = 1,416.7 is fine; OH9000 alone under OC 50 is too.
        r = await api.client.put("/axes/x/speed", json={"oh": 9000})
        assert r.status_code == 200, r.text
        assert (json_of(r)["oh"], json_of(r)["oc"]) == (9000, 50)
        assert sets(api.heard("1", mark)) == ["OC0", "OH9000", "OC50"]
        # tacc = 8500 / (24,576 x 150) x 300 = 0.69173177... s; ts = 50 / 200 x tacc
        assert json_of(r)["acceleration_time_s"] == pytest.approx(8500 / (24576 * 150) * 300)
        assert json_of(r)["s_curve_time_s"] == pytest.approx(0.25 * 8500 / (24576 * 150) * 300)


async def test_ranges_and_empty_body() -> None:
    async with running_app() as api:
        r = await api.client.put("/axes/x/speed", json={"oh": 20000})
        assert r.status_code == 422 and json_of(r)["field"] == "body.oh"
        r = await api.client.put("/axes/x/speed", json={"ox": 1})
        assert r.status_code == 422 and json_of(r)["field"] == "body.ox"
        r = await api.client.put("/axes/x/speed", json={})
        assert r.status_code == 422
