#!/usr/bin/env python3
"""Writes the single-slip corpus: each case is an example of examples/ with one mistake.

Run from the repository root: `python3 compiler/tests/slips/make.py`. Each case folder
holds the slipped `rules.txt` (and `agents.txt`), `args` (`dim=3` when given) and `slip`:
the file and line the one diagnostic must be on, its code, and what its first fix must do
(`restores`: give back the example as it was; `clean`: give files that check clean;
`none`: no fix is offered). The test
(`compiler/tests/slips.rs`) checks those and the rendered output against `expected.txt`
(UPDATE_GOLDEN=1 rewrites it).
"""
import os, shutil, sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
HERE = os.path.dirname(os.path.abspath(__file__))
LE, LEA = "examples/leader-election/rules.txt", "examples/leader-election/agents-30.txt"
GR, GRA = "examples/gravity/rules.txt", "examples/gravity/agents.txt"
ST, STA = "examples/spanning-tree/rules.txt", "examples/spanning-tree/agents-40.txt"
PF, PFA = "examples/path-finding/rules.txt", "examples/path-finding/agents-wall.txt"
OE, OEA = "examples/odd-even-sort/rules.txt", "examples/odd-even-sort/agents.txt"
BO, BOA = "examples/bouncing/rules.txt", "examples/bouncing/agents.txt"
TO, TOA = "examples/tour/rules.txt", "examples/tour/agents.txt"
MF, MFA = "examples/maxflood/rules.txt", "examples/maxflood/agents.txt"
RL, RLA = "examples/reconfigure-line/rules.txt", "examples/reconfigure-line/agents-30.txt"
G3, G3A = "examples/gravity-3d/rules.txt", "examples/gravity-3d/agents.txt"
ST3, ST3A = "examples/spanning-tree/rules-3d.txt", "examples/spanning-tree/agents-3d.txt"
CO, COA = "examples/counting/rules.txt", "examples/counting/agents-40.txt"
RW, RWA = "examples/reconfigure-walk/rules.txt", "examples/reconfigure-walk/agents-30.txt"

# name, rules, agents, which file the slip is in, find, replace, code, fix, line
# (line: where the diagnostic must be, relative to the changed line: 0 the changed line,
# -1 the line before it), dim (None or 3).
R, A = "rules", "agents"
SLIPS = [
    ("lower-case-state-action", LE, LEA, R, "SLEAD0\n", "sLEAD0\n", "E102", "restores", 0),
    ("lower-case-state-test", LE, LEA, R, "SINIT0\n", "sINIT0\n", "E102", "restores", 0),
    ("counter-set-with-equals", LE, LEA, R, "C01 + C00 0000 #*01", "C01 = C00 #*01", "E201", "restores", 0),
    ("missing-postcondition-last-rule", LE, LEA, R, "C01 A C01 #N01 C01 A C01 #W01 C01 A C01 #E01 C01 A C01 #S01 #*01 + C01 0000 SFOLLW\n", "", "E103", "none", -1),
    ("missing-precondition", LE, LEA, R, ">#*01 C01\n", "", "E104", "none", -1),
    ("missing-name", LE, LEA, R, "adopt\n", "", "E104", "none", 0),
    ("extra-line", LE, LEA, R, "SFOLLW\n", "SFOLLW\nSFOLLW\n", "E105", "none", 1),
    ("priority-letter-l", LE, LEA, R, "adopt\n1\n", "adopt\nl\n", "E205", "restores", 1),
    ("priority-letter-O", ST, STA, R, "joinN\n4\n", "joinN\nO4\n", "E205", "restores", 1),
    ("priority-letter-I", ST, STA, R, "joinS\n1\n", "joinS\nI\n", "E205", "restores", 1),
    ("state-typo-swapped", LE, LEA, R, "SINIT0\n", "SINTI0\n", "W503", "restores", 0),
    ("state-typo-letter", ST, STA, R, "SWAIT0 =#N01 0001", "SWAJT0 =#N01 0001", "W503", "restores", 0),
    ("remote-state-typo", TO, TOA, R, "T1,0,LEAD*", "T1,0,LAED*", "W503", "none", 0),
    ("lower-case-direction-slot", ST, STA, R, "=#N01 0001", "=#n01 0001", "E317", "restores", 0),
    ("lower-case-counter", LE, LEA, R, "C01 A C01 #N01", "c01 A C01 #N01", "E102", "restores", 0),
    ("letter-O-in-N-pattern", GR, GRA, R, "N***0", "N***O", "E304", "restores", 0),
    ("letter-l-in-N-pattern", BO, BOA, R, "!F2,2", "!f2,2", "E102", "restores", 0),
    ("six-characters-in-2d", GR, GRA, R, "N***0", "N***0**", "E302", "restores", 0),
    ("dot-for-comma", GR, GRA, R, "P0,-1", "P0.-1", "E102", "restores", 0),
    ("semicolon-for-comma", BO, BOA, R, "E1,1 !F2,2", "E1;1 !F2,2", "E102", "restores", 0),
    ("blank-inside-offset", GR, GRA, R, "P0,-1", "P0, -1", "E204", "restores", 0),
    ("blank-inside-remote-compare", OE, OEA, R, "V1,0,C00 C00", "V1,0, C00 C00", "E204", "restores", 0),
    ("blank-after-N", GR, GRA, R, "N***0", "N ***0", "E204", "restores", 0),
    ("blank-after-S", ST, STA, R, "SWAIT0 =#N01 0001", "S WAIT0 =#N01 0001", "E204", "restores", 0),
    ("blank-after-hash", ST, STA, R, "SWAIT0 =#W01 0001", "SWAIT0 =# W01 0001", "E204", "restores", 0),
    ("blank-inside-slot", ST, STA, R, "SWAIT0 =#E01 0001", "SWAIT0 =#E 01 0001", "E204", "restores", 0),
    ("blank-after-X", OE, OEA, R, "XE S1****", "X E S1****", "E204", "restores", 0),
    ("lower-case-move", GR, GRA, R, "P0,-1", "p0,-1", "E102", "restores", 0),
    ("lower-case-message", PF, PFA, R, "MNpath!", "mNpath!", "E102", "restores", 0),
    ("lower-case-swap", OE, OEA, R, "XE S1****", "xE S1****", "E102", "restores", 0),
    ("comparison-missing-value", GR, GRA, R, ">C00 0000", ">C00", "E202", "none", 0),
    ("letter-l-in-number", GR, GRA, R, "C00 - C00 0001", "C00 - C00 000l", "E102", "restores", 0),
    ("letter-O-in-number", GR, GRA, R, ">C00 0000", ">C00 00O0", "E102", "restores", 0),
    ("letter-O-in-offset", OE, OEA, R, "!W-1,0,C00 C00", "!W-1,O,C00 C00", "E102", "restores", 0),
    ("letter-I-in-offset", BO, BOA, R, "E1,1 !F2,2", "E1,I !F2,2", "E201", "restores", 0),
    ("counter-three-digits", GR, GRA, R, "P0,-1 C00 - C00", "P0,-1 C000 - C00", "E305", "restores", 0),
    ("counter-out-of-range", TO, TOA, R, "C02 + 1,0,C05 0000", "C02 + 1,0,C45 0000", "E305", "none", 0),
    ("slot-one-digit", MF, MFA, R, "C00 A C00 #N01", "C00 A C00 #N1", "E306", "restores", 0),
    ("slot-three-digits", ST, STA, R, "SWAIT0 =#W01 0001", "SWAIT0 =#W001 0001", "E306", "restores", 0),
    ("priority-zero", GR, GRA, R, "fall\n1\n", "fall\n0\n", "E309", "none", 1),
    ("literal-too-large", TO, TOA, R, ">C00 0010", ">C00 40000", "E310", "none", 0),
    ("message-text-short", PF, PFA, R, "MNpath!", "MNpath", "E303", "none", 0),
    ("state-text-short", RL, RLA, R, "S*J1**\n", "S*J1*\n", "E303", "none", 0),
    ("state-text-long", MF, MFA, R, "S*****\n", "S******\n", "E303", "none", 0),
    ("remote-state-short", TO, TOA, R, "T1,0,LEAD*", "T1,0,LEAD", "E303", "none", 0),
    ("too-many-wildcards", TO, TOA, R, "MWping*", "MW*****", "E311", "none", 0),
    ("test-in-postcondition", BO, BOA, R, "P1,1\n", "P1,1 E1,0\n", "E312", "none", 0),
    ("move-in-precondition", BO, BOA, R, "SNE*** E1,1 !F2,2", "SNE*** P1,1 !F2,2", "E313", "none", 0),
    ("two-state-actions", OE, OEA, R, "XE S1**** C01 - 0001 C01 C02 + C02 0001\n", "XE S1**** S0**** C01 - 0001 C01 C02 + C02 0001\n", "E314", "none", 0),
    ("move-and-swap", OE, OEA, R, "XE S1**** C01 - 0001 C01 C02 + C02 0001\n", "XE P1,0 S1**** C01 - 0001 C01 C02 + C02 0001\n", "E315", "none", 0),
    ("offset-three-coordinates-in-2d", BO, BOA, R, "E1,1 !F2,2", "E1,1,0 !F2,2", "E316", "none", 0),
    ("swap-bad-direction", OE, OEA, R, "XE S1****", "XQ S1****", "E317", "none", 0),
    ("swap-wildcard", OE, OEA, R, "XE S1****", "X* S1****", "E318", "none", 0),
    ("remote-compare-no-counter", OE, OEA, R, "V1,0,C00 C00", "V1,0,0 C00", "E319", "none", 0),
    ("negated-move", GR, GRA, R, "P0,-1 C00", "!P0,-1 C00", "E320", "none", 0),
    ("unclosed-parenthesis", BO, BOA, R, "E1,1 !F2,2 !F0,2", "E1,1 (!F2,2 !F0,2", "E203", "none", 0),
    ("stray-parenthesis", BO, BOA, R, "E1,1 !F2,2 !F0,2", "E1,1 !F2,2) !F0,2", "E201", "none", 0),
    ("unknown-letter", GR, GRA, R, "N***0 >C00", "N***0 Z1,0 >C00", "E102", "none", 0),
    ("priority-pattern-short", TO, TOA, R, "P*<**", "P*<*", "E302", "none", 0),
    ("attach-pattern-long", TO, TOA, R, "A0000", "A00000", "E302", "none", 0),
    ("duplicate-rule-name", ST, STA, R, "joinW\n", "joinN\n", "W501", "none", 0),
    ("contradictory-precondition", GR, GRA, R, "N***0 >C00 0000", "N***0 F0,-1 >C00 0000", "W502", "none", 0),
    ("3d-direction-in-2d", OE, OEA, R, "XE S1****", "XA S1****", "E307", "none", 0),
    ("two-coordinates-in-3d", G3, G3A, R, "E0,0,-1", "E0,-1", "E316", "none", 0),
    ("dimension-flag-conflict", GR, GRA, "dim", "", "", "E301", "none", None),
    ("agents-state-short", ST, STA, A, " SWAIT0\n", " SWAIT\n", "E408", "none", 0),
    ("agents-same-cell", LE, LEA, A, None, None, "E402", "none", 0),
    ("agents-three-coordinates", GR, GRA, A, None, None, "E407", "none", 0),
    ("agents-state-typo", ST, STA, A, " SWAIT0\n", " SWIAT0\n", "W603", "restores", 0),
    ("comparison-written-as-assignment", OE, OEA, R, "S0**** =C01 0000", "S0**** C01 = 0000", "E201", "restores", 0),
    ("state-missing-a-character", ST, STA, R, "SWAIT0 =#N01 0001", "SWAT0 =#N01 0001", "E303", "restores", 0),
    # Slips that check but are wrong (issue 33).
    ("comparisons-contradict", GR, GRA, R, "N***0 >C00 0000", "N***0 >C00 0005 <C00 0003", "W502", "none", 0),
    ("move-onto-agent", GR, GRA, R, "N***0 >C00 0000", "N***1 >C00 0000", "W504", "none", 1),
    ("copied-rule-same-priority", ST, STA, R, "joinW\n3\nSWAIT0 =#W01 0001", "joinW\n4\nSWAIT0 =#N01 0001", "W505", "none", 3),
    ("rule-always-outranked", LE, LEA, R, ">#*01 C01\n", "SINIT0 >#*01 C01\n", "W506", "none", -2),
    ("state-set-one-letter-off", RW, RWA, R, "SRWALK #N03 + 0001 0000", "SRWLAK #N03 + 0001 0000", "W507", "restores", 0),
    ("precondition-and-postcondition-swapped", GR, GRA, R, "N***0 >C00 0000\nP0,-1 C00 - C00 0001", "P0,-1 C00 - C00 0001\nN***0 >C00 0000", "E322", "restores", 0),
    ("at-least-written-greater-equal", GR, GRA, R, ">C00 0000", ">=C00 0001", "E201", "clean", 0),
    ("comparison-sign-between-values", GR, GRA, R, ">C00 0000", "C00 > 0000", "E201", "restores", 0),
    ("equality-written-twice", ST, STA, R, "SWAIT0 =#N01 0001", "SWAIT0 ==#N01 0001", "E201", "restores", 0),
    ("missing-priority", GR, GRA, R, "fall\n1\n", "fall\n", "E104", "restores", 0),
]


def slip_agents(name, text):
    """Agents slips that are not a find-and-replace of one place: the changed line index."""
    lines = text.split("\n")
    if name == "agents-same-cell":
        # The second agent put on the first one's cell.
        i = next(k for k, l in enumerate(lines) if l and l[0].isdigit() or l.startswith("-"))
        j = next(k for k in range(i + 1, len(lines)) if lines[k] and (lines[k][0].isdigit() or lines[k][0] == "-"))
        first_pos = lines[i].split()[0]
        rest = lines[j].split(None, 1)
        lines[j] = first_pos + ((" " + rest[1]) if len(rest) > 1 else "")
        return "\n".join(lines), j
    if name == "agents-three-coordinates":
        j = max(k for k, l in enumerate(lines) if l and (l[0].isdigit() or l[0] == "-"))
        parts = lines[j].split(None, 1)
        lines[j] = parts[0] + ",0" + ((" " + parts[1]) if len(parts) > 1 else "")
        return "\n".join(lines), j
    raise ValueError(name)


def main():
    for entry in os.listdir(HERE):
        if os.path.isdir(os.path.join(HERE, entry)):
            shutil.rmtree(os.path.join(HERE, entry))
    for n, (name, rules, agents, where, find, replace, code, fix, rel) in enumerate(SLIPS, 1):
        case = os.path.join(HERE, f"{n:02}-{name}")
        os.makedirs(case)
        rtext = open(os.path.join(ROOT, rules), encoding="utf-8").read()
        atext = open(os.path.join(ROOT, agents), encoding="utf-8").read()
        args, line, in_file, base = "", None, "rules.txt", rules
        if where == "dim":
            args = "dim=3\n"
            first = next(k for k, l in enumerate(atext.split("\n")) if l[:1].isdigit() or l[:1] == "-")
            line, in_file, base = first + 1, "agents.txt", agents
        elif where == R:
            assert rtext.count(find) >= 1, (name, find)
            at = rtext.index(find)
            line = rtext[:at].count("\n") + 1 + rel
            rtext = rtext[:at] + replace + rtext[at + len(find):]
        else:
            in_file, base = "agents.txt", agents
            if find is None:
                atext, j = slip_agents(name, atext)
                line = j + 1 + rel
            else:
                assert find in atext, (name, find)
                at = atext.index(find)
                line = atext[:at].count("\n") + 1 + rel
                atext = atext[:at] + replace + atext[at + len(find):]
        open(os.path.join(case, "rules.txt"), "w", encoding="utf-8").write(rtext)
        open(os.path.join(case, "agents.txt"), "w", encoding="utf-8").write(atext)
        if args:
            open(os.path.join(case, "args"), "w").write(args)
        with open(os.path.join(case, "slip"), "w") as f:
            f.write(f"file {in_file}\nline {line}\ncode {code}\nfix {fix}\nbase {base}\n")
    print(f"{len(SLIPS)} cases")


if __name__ == "__main__":
    sys.exit(main())
