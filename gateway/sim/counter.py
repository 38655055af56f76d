"""The position counter of one axis: output pulses, or (mode 1) the encoder's counts (§7-4).

What command 6 reports, as a function of the mechanical position: in modes 0 and 2 the pulses
output (the mechanics plus what was lost, ``slip``), in mode 1 the encoder count of the
mechanics (``encoder.Encoder``). ``R`` presets the counter in force; a completed search sets
both to 0 (§10 0X ⑤: "現ポジションのクリア", "エンコーダ値のクリア"). A change of mode keeps the
value the counter shows (docs/manual-notes.md, "Mode 1"). The pulses lost since the last plain
motion started are what the encoder's step-out check sees (``deviation``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from gateway.sim.encoder import Encoder

__all__ = ["PositionCounter"]


@dataclass
class PositionCounter:
    """The counter of one axis, and the pulses it lost."""

    offset: int  # pulse counter - mechanical position (0 at power-on)
    encoder: Encoder = field(default_factory=Encoder)
    counts_encoder: bool = False  # mode 1
    slipped: int = 0  # pulses lost since power-on (CW positive)
    slip_mark: int = 0  # ... when the last plain motion started

    def pulses(self, mech: int) -> int:
        """The pulse counter with the axis at ``mech``."""
        return mech + self.offset

    def value(self, mech: int) -> int:
        """What 6 reports with the axis at ``mech`` (before the 24-bit wrap)."""
        return self.encoder.count(mech) if self.counts_encoder else mech + self.offset

    def preset(self, mech: int, value: int) -> None:
        """R: the counter in force reads ``value`` at ``mech``."""
        if self.counts_encoder:
            self.encoder.preset(mech, value)
        else:
            self.offset = value - mech

    def zero(self, mech: int) -> None:
        """A search ended here: the position and the encoder value are 0 (§10 0X ⑤)."""
        self.offset = -mech
        self.encoder.preset(mech, 0)

    def configure(self, mech: int, counts_encoder: bool, pa: int, pb: int) -> None:
        """Mode 1 on or off, PA and PB, with the axis at ``mech``; the value shown stays."""
        if counts_encoder != self.counts_encoder:
            if counts_encoder:
                self.encoder.preset(mech, mech + self.offset)
            else:
                self.offset = self.encoder.count(mech) - mech
            self.counts_encoder = counts_encoder
        self.encoder.set_ratio(mech, pa, pb)

    def pulses_to(self, here: int, target: int) -> int:
        """Signed output pulses from ``here`` that bring the counter to ``target``."""
        if not self.counts_encoder:
            return target - self.value(here)
        return self.encoder.landing(here, target) - here

    def lose(self, pulses: int) -> None:
        """``pulses`` lost (CW positive): the mechanics moved, the pulse counter did not."""
        self.offset -= pulses
        self.slipped += pulses

    def mark(self) -> None:
        """A plain motion starts: the deviation counts from here."""
        self.slip_mark = self.slipped

    @property
    def deviation(self) -> int:
        """Pulses lost since the last plain motion started."""
        return self.slipped - self.slip_mark
