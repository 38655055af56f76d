"""The command names of the manual's chapters 10 and 12, as its index lists them."""

from __future__ import annotations

# The manual's index of chapter 10 (host commands, "" to V) and chapter 12 (user-program
# commands), written out here so that a command dropped from the catalog fails a test.
CHAPTER_10 = (  # noqa: SIM905 - a list the way the manual's index reads
    '"" 0 0A 0B 0H 0Q 0R 0S 0X 0Z 1 2 3 4 5 6 7 7* 8 8* 9 A AL AW B B+(-) C CI CL CO D DL DS '
    "DW E EA ED EE EE/// EL EP ER ES F G GA GC GE GES GN GR GRT GS GSS GW GWT H I IL IR IW K "
    "L N OC OH OL OS OX P PA PB Q QE QJ QS QSE R RD S SS SUM T V"
).split()


CHAPTER_12 = (  # noqa: SIM905
    "/ /AND /BS /CC /CD /CO /CS /CU /EC /END /G /I1 /IL /J /JB /JC /JE /JM /JO /JP /JR /JT "
    "/LD /O /OR /RR /RL /SC /SR /T /TB /TS /WAW /WDW /?"
).split()
