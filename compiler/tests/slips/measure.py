#!/usr/bin/env python3
"""Measures the checker on single slips a rule author makes, as issue 33's targets ask:
slips of the kinds the corpus (make.py) holds, typed into examples other than the ones the
corpus uses for that kind, run through the command a user runs (`latticesim check
--format json`). Nothing here is asserted: it prints, per slip, what the checker said, and
the rates (one diagnostic, on the slip's line, a fix, the first fix giving back the example;
semantic slips caught).

Run from the repository root after `cargo build --release`:
`python3 compiler/tests/slips/measure.py [path/to/latticesim]`.
"""
import json, os, subprocess, sys, tempfile

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
EXE = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "target", "release", "latticesim")

sys.dont_write_bytecode = True  # (a __pycache__ folder would read as a case of the corpus)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make import G3, G3A, MF, MFA, PF, PFA, RL, RLA, ST3, ST3A, TO, TOA  # noqa: E402

# Examples the corpus does not use.
CO3, CO3A = "examples/counting/rules-3d.txt", "examples/counting/agents-3d.txt"
BB, BBA = "examples/bounding-box/rules.txt", "examples/bounding-box/agents-40.txt"

# name, rules, agents, find, replace (the first occurrence, in the rules file), the line of
# the slip relative to the first changed line, semantic (a slip that checks but is wrong).
SLIPS = [
    # Typos and look-alike characters.
    ("state-typo-test", CO3, CO3A, "SWAIT0 =#A01", "SWIAT0 =#A01", 0, False),
    ("state-letter-set", RL, RLA, "STREE0 C11", "STRE0 C11", 0, False),
    ("direction-lower", PF, PFA, "MNpath!", "Mnpath!", 0, False),
    ("counter-O", RL, RLA, "C15 + 0009 0000", "C15 + 0O09 0000", 0, False),
    ("slot-l", CO3, CO3A, "=#B01 0001", "=#B0l 0001", 0, False),
    ("priority-O", PF, PFA, "reachN\n5\n", "reachN\nO5\n", 1, False),
    ("priority-l", ST3, ST3A, "root\n1\n", "root\nl\n", 1, False),
    ("lower-term-letter", BB, BBA, "SWAIT0", "sWAIT0", 0, False),
    ("blank-in-offset", G3, G3A, "P0,0,-1", "P0, 0,-1", 0, False),
    ("blank-in-slot", CO3, CO3A, "#*01 + 0001 0000 #N02", "#*01 + 0001 0000 # N02", 0, False),
    ("comma-as-dot", G3, G3A, "E0,0,-1", "E0.0,-1", 0, False),
    ("counter-three-digits", RL, RLA, "C15 + 0009 0000", "C015 + 0009 0000", 0, False),
    # Operators and forms of other languages.
    ("greater-equal", PF, PFA, ">#N01 0000", ">=#N01 0000", 0, False),
    ("less-equal-counter", CO3, CO3A, "=C12 C10", "<=C12 C10", 0, False),
    ("double-equals", ST3, ST3A, "=#N01 0001", "==#N01 0001", 0, False),
    ("infix-comparison", RL, RLA, "=#W01 0001", "#W01 = 0001", 0, False),
    ("infix-greater", PF, PFA, ">#W01 0000", "#W01 > 0000", 0, False),
    # Lines.
    ("swapped-lines", G3, G3A, "E0,0,-1\nP0,0,-1", "P0,0,-1\nE0,0,-1", 0, False),
    ("swapped-lines-2", PF, PFA, "S*0*** >#E01 0000\nS*1E** C01 + #E01 0000 #*01 + C01 0001",
     "S*1E** C01 + #E01 0000 #*01 + C01 0001\nS*0*** >#E01 0000", 0, False),
    ("missing-priority", BB, BBA, "\n1\nSROOT0", "\nSROOT0", -1, False),
    ("missing-priority-2", CO3, CO3A, "tick\n1\n", "tick\n", 0, False),
    # Terms written wrongly.
    ("message-pattern-short", PF, PFA, "MWpath!", "MWpath", 0, False),
    ("message-no-direction", PF, PFA, "MEpath!", "Mpath!", 0, False),
    ("counter-with-blank", RL, RLA, "C15 + 0009 0000", "C 15 + 0009 0000", 0, False),
    ("comparison-no-value", PF, PFA, ">#S01 0000", ">#S01", 0, False),
    ("calc-missing-operand", CO3, CO3A, "C10 + #N02 #W02", "C10 + #N02", 0, False),
    ("state-six-chars", TO, TOA, "SSLEEP", "SSLEEPY", 0, False),
    # Semantic slips: they check, but are wrong.
    ("set-state-swapped-letters", RL, RLA, "STREE0 C11 + #N02 0000", "STERE0 C11 + #N02 0000", 0, True),
    ("set-state-letter", RL, RLA, "SRIDLE C11 + #N02 0000", "SRIDEL C11 + #N02 0000", 0, True),
    ("contradictory-comparisons", MF, MFA, "S*****\n", "S***** >C00 0009 <C00 0002\n", 0, True),
    ("contradictory-comparisons-2", PF, PFA, "S*0*** >#N01 0000", "S*0*** >#N01 0000 <#N01 0000", 0, True),
    ("move-onto-occupied", G3, G3A, "E0,0,-1", "F0,0,-1", 1, True),
    ("same-priority-copy", ST3, ST3A, "joinW\n5\nSWAIT0 =#W01 0001", "joinW\n6\nSWAIT0 =#N01 0001", 3, True),
    ("outranked-rule", PF, PFA, "S*0*** >#S01 0000", "S*0*** >#N01 0000", -2, True),
    ("tested-state-nobody-has", TO, TOA, "SSLEEP", "SSLEPE", 0, True),
]


def check(rules, agents):
    with tempfile.TemporaryDirectory() as d:
        r, a = os.path.join(d, "rules.txt"), os.path.join(d, "agents.txt")
        open(r, "w").write(rules)
        open(a, "w").write(agents)
        out = subprocess.run([EXE, "check", r, "--agents", a, "--format", "json"],
                             capture_output=True, text=True).stdout
        return json.loads(out)


def apply(text, fix, name):
    edits = sorted((e for e in fix["edits"] if e["file"].endswith(name)),
                   key=lambda e: e["start_byte"], reverse=True)
    b = text.encode()
    for e in edits:
        b = b[:e["start_byte"]] + e["replacement"].encode() + b[e["end_byte"]:]
    return b.decode()


def main():
    rows, counts = [], dict(one=0, line=0, fix=0, restores=0, plain=0, semantic=0, caught=0)
    for name, rf, af, find, replace, rel, semantic in SLIPS:
        rtext = open(os.path.join(ROOT, rf)).read()
        atext = open(os.path.join(ROOT, af)).read()
        assert find in rtext, (name, find)
        at = rtext.index(find)
        line = rtext[:at].count("\n") + 1 + rel
        if find.startswith("\n"):
            line += 1
        slipped = rtext[:at] + replace + rtext[at + len(find):]
        j = check(slipped, atext)
        diags = j["diagnostics"]
        n = j["errors"] + j["warnings"]
        if semantic:
            counts["semantic"] += 1
            counts["caught"] += n > 0
        else:
            counts["plain"] += 1
        one = n == 1
        on_line = one and diags[0]["line"] == line
        fix = one and bool(diags[0]["fixes"])
        restores = False
        if fix:
            fixed = apply(slipped, diags[0]["fixes"][0], "rules.txt")
            restores = fixed == rtext
        counts["one"] += one
        counts["line"] += on_line
        counts["fix"] += fix
        counts["restores"] += restores
        said = ", ".join(f"{d['code']}@{d['line']}" for d in diags) or "nothing"
        rows.append(f"{name:32} {said:24} line {line:4} fix {'yes' if fix else 'no ':3} restores {'yes' if restores else 'no'}")
    print("\n".join(rows))
    total = len(SLIPS)
    pct = lambda a, b: f"{100 * a / b:.0f}% ({a}/{b})" if b else "-"
    print(f"\none diagnostic: {pct(counts['one'], total)}; on the slip's line: {pct(counts['line'], counts['one'])} of those")
    print(f"a fix: {pct(counts['fix'], total)}; the fix gives the example back: {pct(counts['restores'], counts['fix'])}")
    print(f"semantic slips caught: {pct(counts['caught'], counts['semantic'])}")


if __name__ == "__main__":
    main()
