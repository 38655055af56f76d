"""What survives a power cycle: the EEPROM commands of §10 and the power-on loads of §11-2.

- §10 DW: the listed settings (both motors' values, in separate areas) to EEPROM; '>' at once,
  ``$B#*`` CR when the write ends. §10 DL / power-on: DL runs by itself once DW was executed.
- §10 AW / AL: the 1000 ``A`` positions; §10 IW / IL: the user program.
- §10 GA: the autostart flag, written to EEPROM at once; §10 ES: the baud rate, likewise.
- §10 AL ②, DL ②: AL / DL when nothing was written copy the factory values into RAM.
- §10 EE///: '>' at once, 10-20 s of erasing during which commands get no reply at all, then
  ``$B#*`` CR; everything AW, DW, IW, GA and ES wrote is gone (factory values at power-on).
- §10 ES 注意点: body switch F, power on, '/' alone, switch back, power on: all EEPROM data
  erased and the factory settings back.

A power cycle is tested two ways: ``Direct.power_cycle`` (the same controller object) and a new
``Direct`` over the same EEPROM directory (the simulator restarted).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from gateway.sim.scene import AxisScene
from tests.sim.direct import Direct

ACK = b">"
DONE = b"$1*\r"  # §10 AW, DW, IW, EE///: [$ B# * CR]
#: The manual gives no write time for DW/AW/IW; well within a minute is assumed.
WRITE_WAIT = 60.0
#: §10 EE/// 注意点: "EEPROM 内のデータを消去するためには、10~20秒が必要です".
ERASE_MIN, ERASE_MAX = 10.0, 20.0
#: A user program from §11-3 1. ("例) /0//JON1+1/END/3//END").
PROGRAM = "/0//JON1+1/END/3//END"


def new_direct(eeprom_dir: Path) -> Direct:
    """A restarted simulator over ``eeprom_dir``, its frame reader told about SUM1."""
    direct = Direct(eeprom_dir=eeprom_dir)
    _sync_reader(direct)
    return direct


def power_cycle(direct: Direct) -> None:
    """Switch body 1 off and on."""
    direct.power_cycle()
    _sync_reader(direct)


def _sync_reader(direct: Direct) -> None:
    # The harness tells its reader about SUM1 only after a frame; a controller that powers up
    # with SUM1 from EEPROM needs it before the first frame.
    direct.reader.set_checksum("1", direct["1"].framing.checksum)


def written(direct: Direct, text: str) -> None:
    """Send an EEPROM write: '>' now, ``$1*`` CR later and only once."""
    assert direct.cmd(text) == ACK
    direct.advance(WRITE_WAIT)
    assert direct.due() == [DONE]


def restart(direct: Direct, how: str, eeprom_dir: Path) -> Direct:
    """Power-cycle the controller (``cycle``) or restart the simulator (``new``)."""
    if how == "cycle":
        power_cycle(direct)
        return direct
    return new_direct(eeprom_dir)


HOW = ["cycle", "new"]


# ============================================================== DW / DL

#: Every target of §10 DW's table (lines 3585-3613), set away from §16, with the query that
#: reads it back. PA, PB, QJ* are mode-1 commands, 0X mode 2 (§10 E0/E1/E2 columns); the
#: others are set in mode 0. They are read back in mode 2 (the stored E, see FINAL_MODE) except
#: the mode-1 ones and QE (modes 0 and 1). The EE and SUM switches have their own tests.
DW_TARGETS = [
    # (setting, mode to set it in, query, mode to read it in, reply)
    ("0B3", 0, "0B", 2, b">$13\r"),
    ("0Q20", 0, "0QD", 2, b">$100020\r"),
    ("0S40", 0, "0S", 2, b">$100040\r"),
    ("0X1", 2, "0X", 2, b">$11\r"),
    ("0Z3", 0, "0ZD", 2, b">$13\r"),
    ("2123", 0, "2D", 2, b">$1+0000123\r"),  # signed: EP1 was stored with it
    ("EA0E", 0, "EA", 2, b">$10E\r"),
    ("ED0", 0, "ED", 2, b">$10\r"),
    ("EP1", 0, "EP", 2, b">$11\r"),
    ("K5,3", 0, "K", 2, b">$15,08\r"),  # docs/manual-notes.md "K reply": bit 3 as mask 08
    ("OC10", 0, "OC", 2, b">$1010\r"),
    ("OH6000", 0, "OH", 2, b">$106000\r"),
    ("OL600", 0, "OL", 2, b">$100600\r"),
    ("OS400", 0, "OS", 2, b">$100400\r"),
    ("OX600", 0, "OX", 2, b">$100600\r"),
    ("PA2", 1, "PA", 1, b">$12\r"),
    ("PB20", 1, "PB", 1, b">$1020\r"),
    ("Q500", 0, "QD", 2, b">$100500\r"),
    ("QE5", 0, "QE", 1, b">$15\r"),
    ("QJ11", 1, "QJ", 1, b">$111\r"),
    ("QJA900", 1, "QJA", 1, b">$100900\r"),
    ("QJO10", 1, "QJO", 1, b">$100010\r"),
    ("QJT5", 1, "QJT", 1, b">$1005\r"),
    ("QS11", 0, "QS", 2, b">$111\r"),
]
FINAL_MODE = 2  # E is a DW target too: the settings end in mode 2


def _set_everything(direct: Direct) -> None:
    for mode in (0, 1, 2):
        assert direct.cmd(f"E{mode}") == ACK
        for setting, target_mode, _, _, _ in DW_TARGETS:
            if target_mode == mode:
                assert direct.cmd(setting) == ACK, setting
    assert direct.cmd("EL1") == b">\r"
    assert direct.cmd("ER1") == b">\r"
    assert direct.cmd(f"E{FINAL_MODE}") == b">\r"
    # Motor 2 gets other per-motor values (§10 DW 注: both motors in separate areas).
    assert direct.cmd("F2") == b">\r"
    for text in ("OH7000", "OL700", "OS500", "OC20", "0S60", "0B4", "Q600", "0Q30", "EA08"):
        assert direct.cmd(text) == b">\r", text
    assert direct.cmd("F1") == b">\r"
    assert direct.cmd("") == b">$10\r", "a setting was refused"


def _check_everything(direct: Direct) -> None:
    assert direct.cmd("E") == b">$1%d\r" % FINAL_MODE
    assert direct.cmd("EL") == b">$11\r"
    assert direct.cmd("ER") == b">$11\r"
    assert direct.cmd("XYZ") == b">@\r"  # EL1 + ER1 are in force from power-on
    assert direct.cmd("") == b">$18\r"
    for _, _, query, read_mode, reply in DW_TARGETS:
        assert direct.cmd(f"E{read_mode}") == b">\r"
        assert direct.cmd(query) == reply, query
    assert direct.cmd("E2") == b">\r"
    direct.cmd("F2")
    for query, reply in [
        ("OH", b">$107000\r"), ("OL", b">$100700\r"), ("OS", b">$100500\r"),
        ("OC", b">$1020\r"), ("0S", b">$100060\r"), ("0B", b">$14\r"), ("QD", b">$100600\r"),
        ("0QD", b">$100030\r"), ("EA", b">$108\r"),
    ]:  # fmt: skip
        assert direct.cmd(query) == reply, f"motor 2 {query}"


@pytest.mark.parametrize("how", HOW)
def test_dw_keeps_every_target_over_a_power_cycle(how: str, tmp_path: Path) -> None:
    direct = new_direct(tmp_path)
    _set_everything(direct)
    assert direct.cmd("DW") == b">\r"  # '>' at reception (EL1 is on)
    direct.advance(WRITE_WAIT)
    assert direct.due() == [DONE]  # EL does not touch $B#* CR
    direct = restart(direct, how, tmp_path)
    _check_everything(direct)


@pytest.mark.parametrize("how", HOW)
def test_without_dw_every_target_is_back_to_factory(how: str, tmp_path: Path) -> None:
    direct = new_direct(tmp_path)
    _set_everything(direct)
    direct = restart(direct, how, tmp_path)
    assert direct.cmd("E") == b">$10\r"
    assert direct.cmd("OH") == b">$105000\r"
    assert direct.cmd("XYZ") == ACK


@pytest.mark.parametrize(
    ("setting", "query", "factory"),
    [
        ("F2", "F", b">$11\r"),  # §16 F: not a DW target
        ("N11000,2000", "N1", b">$100000,00000000\r"),  # §16 N
        ("NS", "N", b">$10\r"),
        ("D5A", "CO", b">$100\r"),  # §16 D
        ("A500123", "A500D", b">$100000000\r"),  # §16 A: AW, not DW
        ("QSE11", "QSE", b">$100\r"),  # §16 QSE: absent from §10 DW's table
    ],
)
def test_values_dw_does_not_store_are_back_to_factory(
    setting: str, query: str, factory: bytes, tmp_path: Path
) -> None:
    direct = new_direct(tmp_path)
    assert direct.cmd(setting) == ACK
    written(direct, "DW")
    power_cycle(direct)
    assert direct.cmd(query) == factory


def test_dw_overwrites_the_previous_write(tmp_path: Path) -> None:
    # §10 DW 注意点: the RAM values are written and what the EEPROM held before is discarded.
    direct = new_direct(tmp_path)
    direct.cmd("OH6000")
    written(direct, "DW")
    direct.cmd("OH7000")
    written(direct, "DW")
    power_cycle(direct)
    assert direct.cmd("OH") == b">$107000\r"


def test_dw_takes_the_values_of_the_moment_it_is_received(tmp_path: Path) -> None:
    direct = new_direct(tmp_path)
    direct.cmd("OH6000")
    written(direct, "DW")
    direct.cmd("OH7000")  # after the write: RAM only
    power_cycle(direct)
    assert direct.cmd("OH") == b">$106000\r"


def test_dl_reloads_what_dw_wrote(tmp_path: Path) -> None:
    # §10 DL ②: DL discards the RAM values and takes the EEPROM ones.
    direct = new_direct(tmp_path)
    direct.cmd("OH6000")
    written(direct, "DW")
    direct.cmd("OH7000")
    assert direct.cmd("DL") == ACK
    assert direct.cmd("OH") == b">$106000\r"


def test_dl_without_dw_copies_the_factory_values(tmp_path: Path) -> None:
    # §10 DL ②: コマンド "DW" の実行がされていない時に、コマンド "DL" を実行すると、RC-233 初期
    # 設定値が RAM にコピーされます.
    direct = new_direct(tmp_path)
    for text in ("OH6000", "OC10", "EP1", "2123", "F2", "OH7000", "F1"):
        direct.cmd(text)
    assert direct.cmd("DL") == ACK
    assert direct.cmd("OH") == b">$105000\r"
    assert direct.cmd("OC") == b">$1000\r"
    assert direct.cmd("EP") == b">$10\r"
    assert direct.cmd("2D") == b">$100000000\r"
    direct.cmd("F2")
    assert direct.cmd("OH") == b">$105000\r"


def test_dw_with_echo_on_comes_back_with_echo(tmp_path: Path) -> None:
    # §10 DW table: EE is a DW target.
    direct = new_direct(tmp_path)
    direct.cmd("EE1")
    assert direct.cmd("DW") == b"$1DW\r"  # a general reply with echo is the echo alone
    direct.advance(WRITE_WAIT)
    assert direct.due() == [DONE]
    power_cycle(direct)
    assert direct.cmd("") == b"$1\r$10\r"
    assert direct.cmd("EE") == b"$1EE\r$11\r"


@pytest.mark.parametrize("how", HOW)
def test_dw_with_sum_on_comes_back_with_sum(how: str, tmp_path: Path) -> None:
    # §10 DW table: SUM is a DW target.
    direct = new_direct(tmp_path)
    direct.cmd("SUM1")
    assert direct.send(b"$1DW" + b"%02X" % (sum(b"$1DW") % 256) + b"\r") == ACK
    direct.advance(WRITE_WAIT)
    assert direct.due() == [b"$1*7F\r"]  # docs/manual-notes.md "Checksums of unsolicited"
    direct = restart(direct, how, tmp_path)
    assert direct.send(b"$1\r") == b"?"  # a frame without checksum (§10 SUM)
    assert direct.send(b"$155\r") == b">$10C3\r"  # §10 SUM examples


# ============================================================== AW / AL


@pytest.mark.parametrize("how", HOW)
def test_aw_keeps_the_position_table(how: str, tmp_path: Path) -> None:
    direct = new_direct(tmp_path)
    for text in ("A000000001", "A50012345", "A99916777215"):
        assert direct.cmd(text) == ACK
    written(direct, "AW")
    direct = restart(direct, how, tmp_path)
    assert direct.cmd("A000D") == b">$100000001\r"
    assert direct.cmd("A500D") == b">$100012345\r"
    assert direct.cmd("A999D") == b">$116777215\r"
    assert direct.cmd("A001D") == b">$100000000\r"


def test_al_reloads_what_aw_wrote(tmp_path: Path) -> None:
    direct = new_direct(tmp_path)
    direct.cmd("A500111")
    written(direct, "AW")
    direct.cmd("A500222")
    assert direct.cmd("AL") == ACK
    assert direct.cmd("A500D") == b">$100000111\r"


def test_al_without_aw_copies_the_factory_values(tmp_path: Path) -> None:
    # §10 AL ②: AW not executed -> AL copies the initial values (0, §16 A) into RAM.
    direct = new_direct(tmp_path)
    direct.cmd("A500111")
    assert direct.cmd("AL") == ACK
    assert direct.cmd("A500D") == b">$100000000\r"


def test_aw_does_not_store_the_dw_targets(tmp_path: Path) -> None:
    direct = new_direct(tmp_path)
    direct.cmd("OH6000")
    written(direct, "AW")
    power_cycle(direct)
    assert direct.cmd("OH") == b">$105000\r"


# ============================================================== IW / IL


def upload(direct: Direct, program: str) -> None:
    """§10 I, §11-3 1.: "$1I" CR -> '>', then the program text and CR -> '>'."""
    assert direct.cmd("I") == ACK
    assert direct.send(program.encode("latin-1") + b"\r") == ACK


@pytest.mark.parametrize("how", HOW)
def test_iw_keeps_the_user_program(how: str, tmp_path: Path) -> None:
    direct = new_direct(tmp_path)
    upload(direct, PROGRAM)
    written(direct, "IW")
    direct = restart(direct, how, tmp_path)
    # §10 IL ①: the program comes back into RAM at power-on (IR framing: docs/manual-notes.md).
    assert direct.cmd("IR") == f">$1{PROGRAM}\r".encode("latin-1")


def test_il_reloads_what_iw_wrote(tmp_path: Path) -> None:
    direct = new_direct(tmp_path)
    upload(direct, PROGRAM)
    written(direct, "IW")
    upload(direct, "/D00/END")
    assert direct.cmd("IL") == ACK
    assert direct.cmd("IR") == f">$1{PROGRAM}\r".encode("latin-1")


def test_il_without_iw_leaves_no_program(tmp_path: Path) -> None:
    # Nothing was written: the factory state has no user program (docs/manual-notes.md "IR
    # reply": empty data is "no program").
    direct = new_direct(tmp_path)
    upload(direct, PROGRAM)
    assert direct.cmd("IL") == ACK
    assert direct.cmd("IR") == b">$1\r"


def test_without_iw_the_program_is_lost_at_power_off(tmp_path: Path) -> None:
    # §11-3 3.: the program in RAM disappears when the power goes off.
    direct = new_direct(tmp_path)
    upload(direct, PROGRAM)
    power_cycle(direct)
    assert direct.cmd("IR") == b">$1\r"


# ============================================================== GA and ES


@pytest.mark.parametrize("how", HOW)
def test_ga_is_written_at_once(how: str, tmp_path: Path) -> None:
    # §10 GA: オート・スタートの情報は EEPROM に書き込まれ; replies (I), (II) are '>' only.
    direct = new_direct(tmp_path)
    assert direct.cmd("GAS") == ACK
    direct.advance(WRITE_WAIT)
    assert direct.due() == []
    direct = restart(direct, how, tmp_path)
    assert direct.cmd("GA") == b">$11\r"
    assert direct.cmd("GAR") == ACK
    direct = restart(direct, how, tmp_path)
    assert direct.cmd("GA") == b">$10\r"


@pytest.mark.parametrize("how", HOW)
def test_es_is_written_at_once(how: str, tmp_path: Path) -> None:
    # §10 ES: 同時に変更したボーレイトのデータを EEPROM に書き込みます; 電源 ON 毎に呼び出され.
    direct = new_direct(tmp_path)
    assert direct.cmd("ES1") == ACK
    assert direct.cmd("ES") == b">$11\r"
    assert direct.due() == []
    direct = restart(direct, how, tmp_path)
    assert direct.cmd("ES") == b">$11\r"
    assert direct["1"].baud.bps == 1200
    assert direct.cmd("ES0") == ACK  # §10 ES 注意点: "ES0" restores the shipping setting
    direct = restart(direct, how, tmp_path)
    assert direct.cmd("ES") == b">$10\r"
    assert direct["1"].baud.bps == 9600


def test_dw_does_not_store_the_baud_rate(tmp_path: Path) -> None:
    direct = new_direct(tmp_path)
    direct.cmd("ES2")
    written(direct, "DW")
    assert direct.cmd("ES0") == ACK
    power_cycle(direct)
    assert direct.cmd("ES") == b">$10\r"


# ============================================================== EE/// (erase)


def _write_all_areas(direct: Direct) -> None:
    direct.cmd("OH6000")
    written(direct, "DW")
    direct.cmd("A500123")
    written(direct, "AW")
    upload(direct, PROGRAM)
    written(direct, "IW")
    assert direct.cmd("GAS") == ACK
    assert direct.cmd("ES1") == ACK


def _assert_factory(direct: Direct) -> None:
    assert direct.cmd("OH") == b">$105000\r"
    assert direct.cmd("A500D") == b">$100000000\r"
    assert direct.cmd("IR") == b">$1\r"
    assert direct.cmd("GA") == b">$10\r"
    assert direct.cmd("ES") == b">$10\r"
    assert direct["1"].baud.bps == 9600


def test_erase_answers_ack_then_is_deaf_until_the_erase_ends(tmp_path: Path) -> None:
    direct = new_direct(tmp_path)
    _write_all_areas(direct)
    assert direct.cmd("EE///") == ACK
    start = direct.now
    # §10 EE/// 注意点: commands sent while erasing are ignored and get no reply at all.
    for offset in (0.0, 0.001, 1.0, 5.0, ERASE_MIN - 0.01):
        direct.now = start + offset
        assert direct.cmd("") == b"", offset
        assert direct.cmd("OH7000") == b"", offset
        assert direct.due() == [], offset
    direct.now = start + ERASE_MAX
    assert direct.due() == [DONE]  # $B#* CR when the erase is complete
    assert direct.cmd("") == b">$10\r"  # the ignored commands set no flag either
    assert direct.cmd("OH") == b">$106000\r"  # OH7000 was ignored; RAM was not erased
    direct.advance(WRITE_WAIT)
    assert direct.due() == []  # one $1* only


@pytest.mark.parametrize("how", HOW)
def test_erase_brings_back_the_factory_values_at_power_on(how: str, tmp_path: Path) -> None:
    # §10 EE/// 解説: IW, AW, DW, GA and ES data are all erased; §16 注意: EE/// restores the
    # factory initial values.
    direct = new_direct(tmp_path)
    _write_all_areas(direct)
    assert direct.cmd("EE///") == ACK
    direct.advance(ERASE_MAX)
    assert direct.due() == [DONE]
    direct = restart(direct, how, tmp_path)
    _assert_factory(direct)


def test_erase_with_nothing_written(tmp_path: Path) -> None:
    direct = new_direct(tmp_path)
    assert direct.cmd("EE///") == ACK
    direct.advance(ERASE_MAX)
    assert direct.due() == [DONE]
    power_cycle(direct)
    _assert_factory(direct)


def test_erase_then_write_again(tmp_path: Path) -> None:
    # §10 AL ③: the EEPROM keeps data until EE///; after it, it can be written again.
    direct = new_direct(tmp_path)
    _write_all_areas(direct)
    direct.cmd("EE///")
    direct.advance(ERASE_MAX)
    direct.due()
    direct.cmd("OH8000")
    written(direct, "DW")
    power_cycle(direct)
    assert direct.cmd("OH") == b">$108000\r"
    assert direct.cmd("A500D") == b">$100000000\r"


# ============================================================== body switch F and '/'


def test_inspection_mode_echoes_what_it_hears() -> None:
    # §3-III: body switch F returns every character it receives.
    direct = Direct()
    assert direct["1"].inspect(b"$1OH\r", direct.now) == b"$1OH\r"


@pytest.mark.parametrize("how", HOW)
def test_slash_in_inspection_mode_erases_everything(how: str, tmp_path: Path) -> None:
    # §10 ES 注意点: 9,600 bps, switch F, power on, "/" alone (no "$B#"), switch back, power on:
    # EEPROM に書き込まれた全てのデータが消去され、出荷時の設定値に戻ります.
    direct = new_direct(tmp_path)
    _write_all_areas(direct)
    power_cycle(direct)  # switched to F and powered on
    assert direct["1"].inspect(b"/", direct.now) == b"/"
    direct = restart(direct, how, tmp_path)  # switched back and powered on
    _assert_factory(direct)


def test_other_text_in_inspection_mode_erases_nothing(tmp_path: Path) -> None:
    direct = new_direct(tmp_path)
    _write_all_areas(direct)
    direct["1"].inspect(b"$1OH\r", direct.now)
    direct["1"].inspect(b"//", direct.now)
    power_cycle(direct)
    assert direct.cmd("OH") == b">$106000\r"
    assert direct.cmd("GA") == b">$11\r"


# ============================================================== power cycle and RAM


def test_a_power_cycle_clears_the_flags() -> None:
    direct = Direct()
    direct.cmd("XYZ")
    power_cycle(direct)
    assert direct.cmd("") == b">$10\r"
    assert direct.cmd("9") == b">$100\r"


def test_a_write_interrupted_by_power_off_sends_no_done_message(tmp_path: Path) -> None:
    direct = new_direct(tmp_path)
    assert direct.cmd("AW") == ACK
    power_cycle(direct)
    direct.advance(WRITE_WAIT)
    assert direct.due() == []


def test_power_off_stops_the_motor_and_power_on_keeps_the_machine_where_it_is() -> None:
    # Without power there are no pulses; after power-on the counter reads 0 (RAM lost,
    # §9-1) but the axis did not move: a limit or ORG still sits at the same distance.
    direct = Direct()
    ctl = direct["1"]
    assert direct.cmd("7") == b">"  # jog CW at 500 pps from the scene's start
    direct.advance(1.0)
    ctl.power_off(direct.now)
    stopped_at = ctl.axes[1].mechanical(direct.now)
    direct.advance(1.0)
    assert ctl.axes[1].mechanical(direct.now) == stopped_at
    assert direct.cmd("") == b""  # a switched-off controller hears nothing
    direct.power_cycle()
    assert direct.cmd("6") == b">$100000000\r"
    assert ctl.axes[1].mechanical(direct.now) == stopped_at
    assert 495 <= stopped_at - AxisScene().start <= 505  # about 1 s at fL = 500 pps
