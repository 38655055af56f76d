"""The simulated controller starts with the factory settings of the manual's §16 table.

Every row of §16 (設定コマンドの初期値一覧表) that a query can read is read back through that
query, byte for byte, on a new controller, after a power cycle with an empty EEPROM, and on a
new controller over an empty EEPROM directory. The per-motor rows are read for both motors:
"初期値は、モータ 1, 2 共に同じ値です" (§9-1 注意, §16 注意).

The reply widths are the ones each command's §10 page prints (5 digits for speeds, 3 for OC,
PB and QJT, 8 for positions, ``DT,DUDL`` for K, ...). A row whose query exists only in some
operating modes is read in such a mode (§10 E0/E1/E2 columns): PA, PB and the QJ family in
mode 1, 0X in mode 2. Switching the mode with ``E`` changes no other setting.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.sim.direct import Direct


@dataclass(frozen=True)
class Default:
    """One row of §16 as read through its query."""

    row: str  # the command as §16 names it
    query: str  # the query text after the body number
    reply: bytes  # the exact reply of body 1
    mode: int = 0  # an operating mode in which the query is usable (§10 E0/E1/E2)
    per_motor: bool = False  # stored separately for motors 1 and 2 (§10 F list, §10 0B/0Q/EA)


# §16 設定コマンドの初期値一覧表, copied row by row (manual lines 9352-9391), with the query
# that reads each value and the reply format of that query's §10 page.
SECTION_16 = [
    Default("0B", "0B", b">$12\r", per_motor=True),  # "0S" の倍数 2; §10 0B: DT 1 digit
    Default("0Q", "0QD", b">$100010\r", per_motor=True),  # 10 pulses; §10 0Q (III): 5 digits
    Default("0S", "0S", b">$100020\r", per_motor=True),  # 20; §10 0S: 5 digits
    Default("0X", "0X", b">$10\r", mode=2),  # 0 = 従来のアルゴリズム; mode 2 only (§10 0X)
    Default("0Z", "0ZD", b">$11\r"),  # 1 回 (§10 0Z (III))
    Default("2", "2D", b">$100000000\r"),  # 0; §10 2 (III): 8 digits in EP0
    Default("A", "A000D", b">$100000000\r"),  # 0 for every position number (§10 A)
    Default("A", "A001D", b">$100000000\r"),
    Default("A", "A999D", b">$100000000\r"),
    Default("D", "CO", b">$100\r"),  # 00 = 全出力ポート OFF, read with CO (§10 CO)
    Default("E", "E", b">$10\r"),  # モード 0
    Default("EA", "EA", b">$100\r", per_motor=True),  # 00 = every sensor A contact
    Default("ED", "ED", b">$11\r"),  # 1 = 2P 方式
    Default("EE", "EE", b">$10\r"),  # 0 = 未設定 (§10 EE (III): 5 characters when off)
    Default("EL", "EL", b">$10\r"),
    Default("EP", "EP", b">$10\r"),  # 0 = 0～16,777,215
    Default("ER", "ER", b">$10\r"),
    Default("ES", "ES", b">$10\r"),  # 0 = 9,600 bps
    Default("F", "F", b">$11\r"),  # モータ 1
    Default("GA", "GA", b">$10\r"),  # オート・スタート 未設定
    Default("K", "K", b">$10,00\r"),  # "0, 00"; §10 K (V): DT , DU DL
    Default("N", "N", b">$10\r"),  # 0 = 未設定 (§10 N (V))
    Default("OC", "OC", b">$1000\r", per_motor=True),  # 0 = 台形駆動; 3 digits
    Default("OH", "OH", b">$105000\r", per_motor=True),
    Default("OL", "OL", b">$100500\r", per_motor=True),
    Default("OS", "OS", b">$100300\r", per_motor=True),
    Default("OX", "OX", b">$100300\r"),  # × 1 pps; shared (§10 OX)
    Default("PA", "PA", b">$11\r", mode=1, per_motor=True),  # 1 倍 (§10 PA: mode 1 only)
    Default("PB", "PB", b">$1010\r", mode=1, per_motor=True),  # 1 : 10; 3 digits (§10 PB)
    Default("Q", "QD", b">$100400\r", per_motor=True),  # 400 pulses; §10 Q (III): 5 digits
    Default("QE", "QE", b">$14\r"),  # 4 = ±64 pulses (§10 QE)
    Default("QJ", "QJ", b">$100\r", mode=1),  # motors 1, 2 未設定 (§10 QJ (II): M2 M1)
    Default("QJA", "QJA", b">$100800\r", mode=1),  # 800 pulses; 5 digits
    Default("QJO", "QJO", b">$100000\r", mode=1),  # 0 = 現在の Low Speed; 5 digits
    Default("QJT", "QJT", b">$1003\r", mode=1),  # 3 = 30 ms; 3 digits
    Default("QS", "QS", b">$100\r"),  # 脱調検出しない
    Default("QSE", "QSE", b">$100\r"),  # 使用しない; mode 0 only (§10 QSE)
    Default("SUM", "SUM", b">$10\r"),  # 未設定 (§10 SUM (III): 5 characters when off)
]

# Not in §16 but factory state the manual states elsewhere.
OTHER_POWER_ON = [
    # §10 N (VI): s p, p j 初期値 = 0 for every point; 5 + 8 digits.
    *(Default("N", f"N{pn}", b">$100000,00000000\r") for pn in range(1, 6)),
    # §10 B (V): 【初期値 = 00000】, 5 digits.
    Default("BN", "BN", b">$100000\r"),
    # §8-1 and §10 "" 応答例 (I): no error, motor stopped.
    Default('""', "", b">$10\r"),
    # §10 9 応答例 (I): no error, mode 0, motor 1.
    Default("9", "9", b">$100\r"),
]

ROWS = SECTION_16 + OTHER_POWER_ON


def _ids(row: Default) -> str:
    return f"{row.row}:{row.query or 'NULL'}"


def _read(direct: Direct, row: Default, motor: int = 1) -> bytes:
    """Read one default; switching mode and motor first when the row needs it."""
    if row.mode:
        assert direct.cmd(f"E{row.mode}") == b">"
    if motor != 1:
        assert direct.cmd(f"F{motor}") == b">"
    return direct.cmd(row.query)


@pytest.mark.parametrize("row", ROWS, ids=_ids)
def test_a_new_controller_has_the_factory_value(row: Default) -> None:
    assert _read(Direct(), row) == row.reply


@pytest.mark.parametrize("row", [r for r in ROWS if r.per_motor], ids=_ids)
def test_motor_2_has_the_same_factory_value(row: Default) -> None:
    # §9-1 注意 and §16 注意: "初期値は、モータ 1, 2 共に同じ値です".
    assert _read(Direct(), row, motor=2) == row.reply


@pytest.mark.parametrize("row", ROWS, ids=_ids)
def test_a_power_cycle_with_an_empty_eeprom_restores_the_factory_value(
    row: Default, tmp_path: Path
) -> None:
    direct = Direct(eeprom_dir=tmp_path)
    _change_everything(direct)
    direct.power_cycle()
    assert _read(direct, row) == row.reply


@pytest.mark.parametrize("row", ROWS, ids=_ids)
def test_a_new_controller_over_an_empty_eeprom_directory_has_the_factory_value(
    row: Default, tmp_path: Path
) -> None:
    assert _read(Direct(eeprom_dir=tmp_path), row) == row.reply


def _change_everything(direct: Direct) -> None:
    """Move every §16 setting away from its default in RAM only (nothing written to EEPROM)."""
    texts = [
        "0B3", "0Q20", "0S40", "0Z3", "2123", "A000456", "A999789", "D5A", "EA0E",
        "ED0", "EP1", "K1,01", "OC10", "OH6000", "OL600", "OS400", "OX600", "Q500",
        "QE5", "QS11", "QSE11", "N11000,2000", "NS", "F2",
        "E1", "PA2", "PB20", "QJ11", "QJA900", "QJO10", "QJT5",
        "E2", "0X1",
        "EL1", "ER1",
    ]  # fmt: skip
    for text in texts:
        direct.cmd(text)
    # EL1 is on now: every general reply ends with CR (§10 EL).
    assert direct.cmd("") == b">$10\r", "one of the settings above was refused"
