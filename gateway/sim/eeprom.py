"""The EEPROM of one simulated RC-233: the areas AW, DW, IW, ES and GA write, kept in a file.

A file per controller makes restarting the simulator a power cycle: RAM is lost, what was
written to EEPROM is applied again at power-on (§10 AL, DL, IL, GA, ES; §11-2). The file is
JSON, one object with one key per area; an area never written is absent (the device is shipped
with an empty EEPROM, §3-VII). ``EE///`` and the body-F procedure of §10 ES erase every area.

Write times: the manual gives only the erase time of ``EE///`` (10-20 s, §10 EE///; "about
20 s", §15). The write times of AW, DW and IW are our choice (docs/manual-notes.md, "EEPROM
write times"): long enough that a host which does not wait for ``$B#*`` is caught.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = [
    "ERASE_SECONDS",
    "WRITE_SECONDS",
    "Eeprom",
    "EepromImage",
]

#: Seconds from the '>' of a write command to its ``$B#*`` (our choice, see the module doc).
WRITE_SECONDS = {"DW": 0.1, "AW": 1.5, "IW": 1.5}
#: Seconds ``EE///`` stays silent before ``$B#*`` (§10 EE///: 10-20 s; §15: about 20 s).
ERASE_SECONDS = 20.0


@dataclass
class EepromImage:
    """The written areas; None = never written since shipping or the last erase."""

    dw: dict[str, Any] | None = None  # Settings.dw_image()
    aw: list[int] | None = None  # the 1000 A positions, as counters
    iw: str | None = None  # the user program text
    es: int | None = None  # the ES digit
    ga: bool | None = None  # autostart
    #: Writes so far (AW/DW/IW count against the 100,000 of §3-VII; shown, not enforced)
    writes: int = 0

    def to_json(self) -> dict[str, Any]:
        """The image as the file stores it."""
        data: dict[str, Any] = {"writes": self.writes}
        for key in ("dw", "aw", "iw", "es", "ga"):
            value = getattr(self, key)
            if value is not None:
                data[key] = value
        return data

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> EepromImage:
        """Read back what ``to_json`` wrote."""
        return cls(
            dw=data.get("dw"),
            aw=data.get("aw"),
            iw=data.get("iw"),
            es=data.get("es"),
            ga=data.get("ga"),
            writes=int(data.get("writes", 0)),
        )


class Eeprom:
    """The EEPROM of one controller: in memory, and mirrored to ``path`` when one is given.

    Writes go to the file at once (atomically, through a temporary file and a rename), so a
    simulator killed at any moment comes back with what the controller had written.
    """

    def __init__(self, path: Path | None = None) -> None:
        self.path = path
        self.image = self._load()

    def _load(self) -> EepromImage:
        if self.path is None or not self.path.exists():
            return EepromImage()
        try:
            return EepromImage.from_json(json.loads(self.path.read_text(encoding="utf-8")))
        except (ValueError, KeyError, TypeError) as exc:
            raise ValueError(f"{self.path}: not an RC-233 simulator EEPROM file ({exc})") from exc

    def _save(self) -> None:
        if self.path is None:
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_suffix(".tmp")
        tmp.write_text(json.dumps(self.image.to_json(), indent=1), encoding="utf-8")
        os.replace(tmp, self.path)

    def write(self, area: str, value: Any) -> None:
        """Store one area (``dw``, ``aw``, ``iw``, ``es``, ``ga``)."""
        setattr(self.image, area, value)
        if area in ("dw", "aw", "iw"):
            self.image.writes += 1
        self._save()

    def erase(self) -> None:
        """Erase every area (``EE///``, §10 ES recovery); the write count survives."""
        self.image = EepromImage(writes=self.image.writes)
        self._save()

    @classmethod
    def for_body(cls, directory: Path | None, series: str, body: str) -> Eeprom:
        """The EEPROM of one controller in ``directory`` (None: memory only)."""
        if directory is None:
            return cls()
        name = f"rc233-{'dollar' if series == '$' else 'hash'}-{body}.json"
        return cls(directory / name)
