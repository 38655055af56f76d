"""The ``K`` error output: output-port bits turned ON when a watched error occurs (§10 K).

§10 K 解説: the function watches for *changes*: the limit bit of the status flags going
0 -> 1 while the step-out bit is 0, the EMS bit going 0 -> 1, the step-out bit (9 bit 6) going
0 -> 1. On a watched change the chosen bits of the general output port go ON; they stay ON
until ``KC`` (or ``D``) turns them OFF. ``Flags`` notes the changes as they happen; the
controller hands them here (``apply``) before it acts on the next command, so a host that
reads the port always sees the outputs of every error before its read.
"""

from __future__ import annotations

from gateway.protocol.reply_values import ErrorOutput, ErrorWatch

__all__ = ["apply"]


def apply(setting: ErrorOutput, rises: ErrorWatch, outputs: int) -> int:
    """The output port after the errors that rose (``rises``) under the K ``setting``.

    ``K0`` (watch 0) turns nothing ON; bits already ON stay ON in every case (§10 K 注意点).
    """
    if setting.watch & rises:
        return outputs | setting.outputs.value
    return outputs
