//! What the checker builds and decides, beyond the golden files: the checked program, the
//! dimension rules, the agents configuration.

use latticesim_compiler::checked::{
    Action, AttachLetter, BitPat, Cond, Coord, Dir, Operand, Target, Val,
};
mod common;

use common::run;
use latticesim_compiler::{Checked, Dim};
use latticesim_grammar::Code;

fn codes(c: &Checked) -> Vec<Code> {
    c.diags.iter().map(|d| d.code).collect()
}

#[test]
fn builds_the_checked_program() {
    let c = run(
        "r\n7\nN1*0* P<=** A*1** SAB*DE !(E-1,C03) >#*02 -0005\nP0,-1 A+*01 S**X** M*hello C02 A 1,0,C04 #N08 #E03 - C01 0002 XN\n",
        None,
        None,
    );
    // P with X is an error: check it is the only one.
    assert_eq!(codes(&c), vec![Code::E315]);
    let c = run(
        "r\n7\nN1*0* P<=** A*1** SAB*DE !(E-1,C03) >#*02 -0005\nP0,-1 A+*01 S**X** M*hello C02 A 1,0,C04 #N08 #E03 - C01 0002\n",
        None,
        None,
    );
    assert!(c.diags.is_empty(), "{:?}", c.diags);
    assert_eq!(c.dim.dim, Dim::Two);
    let p = c.rules.unwrap();
    let r = &p.rules[0];
    assert_eq!(r.priority, 7);
    let Cond::And(pre) = &r.pre else { panic!() };
    assert_eq!(
        pre[0],
        Cond::Neighbors(BitPat {
            mask: 0b0101,
            want: 0b0001
        })
    );
    assert_eq!(
        pre[1],
        Cond::Priorities {
            strict: 0b0001,
            leq: 0b0010
        }
    );
    assert_eq!(
        pre[2],
        Cond::Attached(BitPat {
            mask: 0b0010,
            want: 0b0010
        })
    );
    assert_eq!(
        pre[3],
        Cond::State([Some(b'A'), Some(b'B'), None, Some(b'D'), Some(b'E')])
    );
    assert_eq!(
        pre[4],
        Cond::Not(Box::new(Cond::And(vec![Cond::Empty([
            Coord::Lit(-1),
            Coord::Counter(3),
            Coord::Lit(0)
        ])])))
    );
    assert_eq!(
        pre[5],
        Cond::Compare(
            latticesim_compiler::checked::CmpOp::Gt,
            Val::Msg { dir: None, slot: 1 },
            Val::Lit(-5)
        )
    );
    assert_eq!(
        r.post[0],
        Action::Move([Coord::Lit(0), Coord::Lit(-1), Coord::Lit(0)])
    );
    assert_eq!(
        r.post[1],
        Action::Attach(vec![
            AttachLetter::Rigid,
            AttachLetter::Keep,
            AttachLetter::Detach,
            AttachLetter::Attach
        ])
    );
    assert_eq!(
        r.post[3],
        Action::Send {
            dir: None,
            text: *b"hello"
        }
    );
    assert_eq!(
        r.post[4],
        Action::Calc {
            target: Target::Counter(2),
            op: latticesim_compiler::checked::CalcOp::Max,
            lhs: Operand::External {
                x: Coord::Lit(1),
                y: Coord::Lit(0),
                counter: 4
            },
            rhs: Operand::Val(Val::Msg {
                dir: Some(Dir::N),
                slot: 7
            }),
        }
    );
    assert_eq!(
        r.post[5],
        Action::Calc {
            target: Target::Msg {
                dir: Some(Dir::E),
                slot: 2
            },
            op: latticesim_compiler::checked::CalcOp::Sub,
            lhs: Operand::Val(Val::Counter(1)),
            rhs: Operand::Val(Val::Lit(2)),
        }
    );
}

#[test]
fn dimension_from_rules_and_remote_state_split() {
    // The first deciding term is 3D, so T splits after three coordinates.
    let c = run("r\n1\nN1*1*** T1,0,0,ABCDE\nS*****\n", None, None);
    assert!(c.diags.is_empty(), "{:?}", c.diags);
    assert_eq!(c.dim.dim, Dim::Three);
    // In 2D the same characters after two coordinates are a state "0,ABC".
    let c = run("r\n1\nN1*1* T1,0,0,ABC\nS*****\n", None, None);
    assert!(c.diags.is_empty(), "{:?}", c.diags);
    let Cond::And(pre) = &c.rules.unwrap().rules[0].pre else {
        panic!()
    };
    assert_eq!(
        pre[1],
        Cond::RemoteState(
            [Coord::Lit(1), Coord::Lit(0), Coord::Lit(0)],
            [Some(b'0'), Some(b','), Some(b'A'), Some(b'B'), Some(b'C')]
        )
    );
    // A T term that comes before the deciding term is parsed again once the dimension is known.
    // (Alone, `((T1,0,0,ABC))` reads best as 3D with state `ABC))`; the N pattern makes it 2D.)
    let c = run(
        "r\n1\n((T1,0,0,ABC))\nS*****\nq\n1\nN1*0*\nS*****\n",
        None,
        None,
    );
    assert!(c.diags.is_empty(), "{:?}", c.diags);
    assert_eq!(c.dim.dim, Dim::Two);
    let Cond::And(pre) = &c.rules.unwrap().rules[0].pre else {
        panic!()
    };
    assert_eq!(
        pre[0],
        Cond::And(vec![Cond::And(vec![Cond::RemoteState(
            [Coord::Lit(1), Coord::Lit(0), Coord::Lit(0)],
            [Some(b'0'), Some(b','), Some(b'A'), Some(b'B'), Some(b'C')]
        )])])
    );
    // --dim wins over the rules; the agents file wins over the rules.
    let c = run("r\n1\nN1*0*\nS*****\n", None, Some(Dim::Three));
    assert_eq!(codes(&c), vec![Code::E302]);
    let c = run("r\n1\nN1*0*\nS*****\n", Some("0,0,0\n"), None);
    assert_eq!(codes(&c), vec![Code::E302]);
    assert_eq!(
        c.diags[0].secondary.len(),
        1,
        "points at the agents file too"
    );
    // The rules vote: one 3D pattern among 2D terms is the one reported.
    let c = run("a\n1\nN1*0*1*\nP1,0\nb\n1\nE0,1 F1,0\nS*****\n", None, None);
    assert_eq!(c.dim.dim, Dim::Two);
    assert_eq!(codes(&c), vec![Code::E302]);
    assert!(c.dim.why.starts_with("3 of the 4 terms"), "{}", c.dim.why);
    // Nothing decides: 2D.
    let c = run("r\n1\nS*****\nS*****\n", None, None);
    assert_eq!(c.dim.dim, Dim::Two);
}

#[test]
fn every_error_of_a_file_in_one_run_in_file_order() {
    let c = run(
        "a\n1\nN1*0*1\nS*****\nb\n0\nE 1,0 ?\nXQ\nc\n1\nS*****\nE1,0 P1,0 P2,0\n",
        None,
        Some(Dim::Two),
    );
    assert_eq!(
        codes(&c),
        vec![
            Code::E302,
            Code::E309,
            Code::E204,
            Code::E102,
            Code::E317,
            Code::E312,
            Code::E314
        ]
    );
}

#[test]
fn contradictions_only_where_certain() {
    let w = |pre: &str| {
        let c = run(&format!("r\n1\n{pre}\nS*****\n"), None, Some(Dim::Two));
        assert_eq!(c.errors(), 0, "{pre}: {:?}", c.diags);
        c.warnings()
    };
    assert_eq!(w("N1*** N0***"), 1);
    assert_eq!(w("N1*** !N0***"), 0);
    assert_eq!(w("N1*** !(N0*** S*****)"), 0);
    assert_eq!(w("(N1***) (E0,1)"), 1);
    assert_eq!(w("A1*** N0***"), 1);
    assert_eq!(w("A1*** A0***"), 1);
    assert_eq!(w("SA**** S*B***"), 0);
    assert_eq!(w("SA**** SB****"), 1);
    assert_eq!(w("MNa**** MNb****"), 1);
    assert_eq!(w("M*a**** MNb****"), 0);
    assert_eq!(w("E2,3 F2,3"), 1);
    assert_eq!(w("EC01,3 F2,3"), 0);
    assert_eq!(w("T2,3,ABCDE T2,3,ABCDF"), 1);
    assert_eq!(w("<0005 0003"), 1);
    assert_eq!(w("<0003 0005"), 0);
}

#[test]
fn agents_configuration() {
    let c = run(
        "r\n1\nS*****\nS*****\n",
        Some("U-2,2,-2,2\n0,0 SLEAD0 A0010 C03 -7 C00 0\n1,0\n1,1 A0001\n-2,-2 A0100\n"),
        None,
    );
    assert_eq!(codes(&c), vec![Code::W601, Code::W601, Code::W602]);
    let cfg = c.config.unwrap();
    assert_eq!(cfg.universe, Some([(-2, 2), (-2, 2), (0, 0)]));
    assert_eq!(cfg.agents.len(), 4);
    assert_eq!(
        cfg.agents[3].attach, 0,
        "bond towards an empty cell dropped"
    );
    assert_eq!(&cfg.agents[0].state, b"LEAD0");
    assert_eq!(cfg.agents[0].attach, 0b0100, "east bond");
    assert_eq!(
        cfg.agents[1].attach, 0b0011,
        "made symmetric: west bond, and north towards 1,1"
    );
    // 1,1 is attached south to 1,0: symmetric now, so no second warning.
    assert_eq!(cfg.agents[2].attach, 0b1000);
    assert_eq!(cfg.agents[1].attach & 0b0001, 0b0001);
    assert_eq!(cfg.agents[0].counters, vec![(3, -7)]);
}

/// W503 and W603 are one slip each: a misspelt pattern with agents in the right state is
/// one W503 (the agents' place as a secondary label); agents all started in a state no rule
/// knows (`gen` without `--state`) are one W603, not a W503 for every pattern that then
/// matches nothing; a pattern no state matches, with the agents fine, is a W503 of its own.
#[test]
fn state_slips_are_one_warning_each() {
    let rules = "start\n1\nSINIT0\nSLEAD0\n\nlead\n2\nSLEAD0 N1***\nSDONE0\n";
    let misspelt = rules.replace("SINIT0", "SINTI0");
    let c = run(&misspelt, Some("0,0 SINIT0\n1,0 SINIT0\n"), None);
    assert_eq!(codes(&c), [Code::W503]);
    assert_eq!(c.diags[0].secondary.len(), 1);
    assert_eq!(c.diags[0].secondary[0].file.0, 1);
    let c = run(rules, Some("0,0 SXXXX0\n1,0 SXXXX0\n"), None);
    assert_eq!(codes(&c), [Code::W603]);
    let c = run(
        &rules.replace("SLEAD0 N1***", "SLAED0 N1***"),
        Some("0,0 SINIT0\n"),
        None,
    );
    assert_eq!(codes(&c), [Code::W503]);
    assert_eq!(c.diags[0].fixes[0].edits[0].replacement, "LEAD0");
}

/// A state typo in the agents file is fixed in the agents file: where the rules write the
/// state more than once they mean it (no fix of theirs); where once, the rules' fix comes
/// first and the agents file's second. Each fix gives files that check clean. Past
/// `FIXABLE` agents, no agents-file fix (the file was generated).
#[test]
fn a_state_typo_in_the_agents_file_is_fixed_there() {
    let apply = |c: &Checked, k: usize| {
        let f = &c.diags[0].fixes[k];
        let file = f.edits[0].file;
        (file.0, f.apply(c.sources.text(file), file))
    };
    // WALK0 is tested by two rules and set by none; every agent starts in WALX0.
    let rules = "walk\n1\nSWALK0 N**0* >C01 0000\nP1,0 C01 - C01 0001\n\n\
                 stop\n2\nSWALK0 =C01 0000\nC01 + C01 0001\n";
    let typo = "0,0 SWALX0 C01 0003\n5,5 SWALX0\n9,0 SWALX0 C01 0001\n";
    let c = run(rules, Some(typo), None);
    assert_eq!(codes(&c), [Code::W503, Code::W503]);
    assert_eq!(c.diags[0].fixes.len(), 1, "{:?}", c.diags[0].fixes);
    assert!(c.diags[1].fixes.is_empty(), "{:?}", c.diags[1].fixes);
    let (file, fixed) = apply(&c, 0);
    assert_eq!(file, 1);
    assert_eq!(fixed, typo.replace("SWALX0", "SWALK0"));
    assert!(run(rules, Some(&fixed), None).diags.is_empty());
    // Tested once: either file may hold the slip; the rules' fix first.
    let once = "walk\n1\nSWALK0 N**0* >C01 0000\nP1,0 C01 - C01 0001\n";
    let c = run(once, Some(typo), None);
    assert_eq!(codes(&c), [Code::W503]);
    assert_eq!(c.diags[0].fixes.len(), 2);
    let (file, fixed) = apply(&c, 0);
    assert_eq!(file, 0);
    assert!(run(&fixed, Some(typo), None).diags.is_empty());
    let (file, fixed) = apply(&c, 1);
    assert_eq!(file, 1);
    assert!(run(once, Some(&fixed), None).diags.is_empty());
    // A few agents of many: W603, its fix edits each of them.
    let few = "0,0 SWALK0\n1,0 SWALX0\n2,0 SWALK0\n3,0 SWALK0\n4,0 SWALX0\n";
    let c = run(once, Some(few), None);
    assert_eq!(codes(&c), [Code::W603]);
    let (file, fixed) = apply(&c, 0);
    assert_eq!((file, fixed.matches("SWALX0").count()), (1, 0));
    assert!(run(once, Some(&fixed), None).diags.is_empty());
    // More than FIXABLE agents: no fix edits them line by line.
    let many: String = (0..=latticesim_compiler::FIXABLE)
        .map(|i| format!("{i},0 SWALX0\n"))
        .collect();
    let c = run(rules, Some(&many), None);
    assert!(c.diags.iter().all(|d| d.fixes.is_empty()), "{:?}", c.diags);
}

/// Root causes come first: a dimension conflict (in the agents file) and a rule cut short
/// at the end of the file come before the errors earlier in the rules file.
#[test]
fn root_causes_come_first() {
    let rules = "a\n1\nE1,\nS*****\n\nb\n2\n";
    let c = run(rules, Some("0,0\n"), Some(Dim::Three));
    assert_eq!(codes(&c), [Code::E103, Code::E301, Code::E202]);
}

/// Rules and an agents file of different dimensions are not a pair: one E301 on the agents
/// file whatever the number of rules (each file read in its own dimension, so the agents
/// file's own mistakes are still found), either way round; a single term of the other
/// dimension is that term's error, with its fix.
#[test]
fn rules_and_agents_of_two_dimensions_are_one_error() {
    let rules_2d: String = (0..300)
        .map(|i| format!("r{i}\n1\nN***0 E1,0\nP1,0\n\n"))
        .collect();
    let c = run(&rules_2d, Some("0,0,0\n1,0,0 C77 1\n"), None);
    assert_eq!(codes(&c), [Code::E301, Code::E404]);
    assert_eq!(c.diags[0].primary.file.0, 1, "on the agents file");
    assert_eq!(
        c.diags[0].secondary[0].file.0, 0,
        "the rules' term beside it"
    );
    assert_eq!(c.dim.dim, Dim::Two, "the rules read in their own dimension");
    let rules_3d = "r\n1\nN***0** E1,0,0\nP1,0,0\n";
    let c = run(rules_3d, Some("0,0\n"), None);
    assert_eq!(codes(&c), [Code::E301]);
    // One odd term: E302 and its fix, in the agents' dimension.
    let c = run("r\n1\nN1*0*1*\nS*****\n", Some("0,0\n"), None);
    assert_eq!(codes(&c), [Code::E302]);
    assert!(!c.diags[0].fixes.is_empty());
    // With --dim, the flag is the one reconciled with the agents file; rules that side
    // with the flag are read in it.
    let c = run(&rules_2d, Some("0,0,0\n"), Some(Dim::Two));
    assert_eq!(codes(&c), [Code::E301]);
    // Without an agents file the flag decides: 2D rules under --dim 3 are an error per
    // term, never read as 2D.
    let c = run(&rules_2d, None, Some(Dim::Three));
    let k = codes(&c);
    assert!(
        !k.is_empty() && k.iter().all(|&k| k == Code::E302 || k == Code::E316),
        "{k:?}"
    );
    assert_eq!(c.dim.dim, Dim::Three);
}

/// The slips that check but are wrong (issue 33): each told once, with its code, and
/// nothing said where the rules mean what they say.
#[test]
fn semantic_slips_are_told_once_each() {
    let one = |rules: &str, agents: Option<&str>| codes(&run(rules, agents, None));
    // W502: comparisons of one value that cannot hold together.
    for pre in [
        ">C00 0005 <C00 0003",
        "=C00 0002 =C00 0003",
        "<0003 C00 <C00 0002",
        "=#N01 0004 >#N01 0004",
    ] {
        assert_eq!(
            one(&format!("r\n1\n{pre}\nS*****\n"), None),
            [Code::W502],
            "{pre}"
        );
    }
    for pre in [
        ">C00 0002 <C00 0005",
        "=#*01 0001 =#*01 0002",
        ">C00 0001 <C01 0000",
    ] {
        assert_eq!(one(&format!("r\n1\n{pre}\nS*****\n"), None), [], "{pre}");
    }
    // W504: a move onto a cell required to hold an agent; not when a bond carries it.
    assert_eq!(one("up\n1\nN1***\nP0,1\n", None), [Code::W504]);
    assert_eq!(one("up\n1\nT0,1,WALK0\nP0,1\n", None), [Code::W504]);
    assert_eq!(one("up\n1\nN0***\nP0,1\n", None), []);
    assert_eq!(one("up\n1\nA1*** N1***\nP0,1\n", None), []);
    assert_eq!(one("up\n1\nN1***\nP0,1 A+***\n", None), []);
    assert_eq!(one("up\n1\n!N1***\nP0,1\n", None), []);
    // W505: one priority, one precondition (in any order), states set differently; not
    // when a term differs or the characters agree.
    let pair = |p: &str, q: &str, a: &str, b: &str| format!("a\n1\n{p}\n{a}\n\nb\n1\n{q}\n{b}\n");
    assert_eq!(
        one(
            &pair("SW**** N0***", "N0*** SW****", "S*A***", "S*B***"),
            None
        ),
        [Code::W505]
    );
    assert_eq!(
        one(&pair("SW****", "SW****", "P1,0", "P-1,0"), None),
        [Code::W505]
    );
    assert_eq!(
        one(
            &pair("SW**** N0***", "SW**** N*0**", "S*A***", "S*B***"),
            None
        ),
        []
    );
    assert_eq!(one(&pair("SW****", "SW****", "S*A***", "S**B**"), None), []);
    // W506: a higher rule that holds wherever a lower one does; not with priority terms
    // (they depend on the neighbours), nor with a term of its own.
    let ranked = |hi: &str, lo: &str| format!("h\n5\n{hi}\nSDONE0\n\nl\n2\n{lo}\nC00 + C00 0001\n");
    for (hi, lo) in [
        ("SWORK0", "SWORK0 N1***"),
        ("N1**0", "N11*0 SWORK0"),
        (">C00 0000", "SWORK0 >C00 0004"),
        ("S*****", "SWORK0"),
        ("S**R**", "SWORK0"),
    ] {
        assert_eq!(one(&ranked(hi, lo), None), [Code::W506], "{hi} over {lo}");
    }
    for (hi, lo) in [
        ("SWORK0 P<***", "SWORK0"),
        ("SWORK0 L1,0", "SWORK0"),
        ("SWORK0 =C01 0000", "SWORK0"),
        (">C00 0004", "SWORK0 >C00 0000"),
        ("SWORK0 M*ping*", "SWORK0"),
        ("S**X**", "SWORK0"),
    ] {
        assert_eq!(one(&ranked(hi, lo), None), [], "{hi} over {lo}");
    }
    // W507, the state `STOP0` misspelt where it is set.
    let stop = |set: &str, also: &str| {
        format!("go\n1\nSGO000 >C00 0000\nS{set}\n\nstop\n1\nSSTOP0\nSDONE0\n{also}")
    };
    assert_eq!(one(&stop("STPO0", ""), None), [Code::W507]);
    assert_eq!(one(&stop("STOP1", ""), None), [], "a digit is meant");
    assert_eq!(one(&stop("SPOT0", ""), None), [], "not one slip");
    // Another rule sets `STOP0`: certain whatever the agents.
    let halt = "\nhalt\n1\nSHALT0\nSSTOP0\n";
    assert_eq!(
        one(&stop("STPO0", halt), Some("0,0 SGO000 C00 1\n1,0 SHALT0\n")),
        [Code::W507]
    );
    // No rule sets `STOP0`: agents start in it, or the rules write it more often than the
    // slip (the pattern is then not a W503 too); written as often, the pattern is the slip.
    assert_eq!(
        one(&stop("STPO0", ""), Some("0,0 SGO000 C00 1\n1,0 SSTOP0\n")),
        [Code::W507]
    );
    let twice = "\nstop2\n2\nSSTOP0 N1***\nSDONE0\n";
    assert_eq!(
        one(&stop("STPO0", twice), Some("0,0 SGO000 C00 1\n")),
        [Code::W507]
    );
    assert_eq!(
        one(&stop("STPO0", ""), Some("0,0 SGO000 C00 1\n")),
        [Code::W503]
    );
    // The fix writes the tested state, and the file then checks clean.
    let c = run(&stop("STPO0", halt), None, None);
    let text = stop("STPO0", halt);
    let fixed = c.diags[0].fixes[0].apply(&text, c.diags[0].primary.file);
    assert_eq!(fixed, stop("STOP0", halt));
    assert_eq!(one(&fixed, None), []);
}

/// No shipped example warns: each rules file alone, and with each agents file of its
/// folder that is its pair (the same dimension). `examples/mistakes` shows mistakes.
#[test]
fn shipped_examples_check_clean() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
    let mut checked = 0;
    for dir in std::fs::read_dir(&root).unwrap().map(|e| e.unwrap().path()) {
        if !dir.is_dir() || dir.ends_with("mistakes") {
            continue;
        }
        let files: Vec<std::path::PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "txt"))
            .collect();
        let named =
            |p: &std::path::Path, s: &str| p.file_name().unwrap().to_string_lossy().starts_with(s);
        for r in files.iter().filter(|p| named(p, "rules")) {
            let rules = std::fs::read_to_string(r).unwrap();
            let alone = run(&rules, None, None);
            let said = alone.render(false);
            assert_eq!(
                alone.errors() + alone.warnings(),
                0,
                "{}:\n{said}",
                r.display()
            );
            for a in files.iter().filter(|p| named(p, "agents")) {
                // A pair is of one dimension (`-3d` in both names or in neither).
                if named(r, "rules-3d") != named(a, "agents-3d") {
                    continue;
                }
                let agents = std::fs::read_to_string(a).unwrap();
                let c = run(&rules, Some(&agents), None);
                let said = c.render(false);
                assert_eq!(
                    c.errors() + c.warnings(),
                    0,
                    "{} {}:\n{said}",
                    r.display(),
                    a.display()
                );
                checked += 1;
            }
        }
    }
    assert!(checked >= 20, "{checked} pairs checked");
}

/// Slips that used to give several diagnostics give one (issue 33): a message term without
/// its direction, a counter with a blank inside, a number with the letter O read as the
/// number its fix writes (the rest of the line reads as meant), an operator of another
/// language, swapped lines; each fix gives a file that checks clean.
#[test]
fn one_slip_one_diagnostic() {
    let cases = [
        ("MNpath!", "Mpath!", Code::E317, false),
        ("C15 + 0009 0000", "C 15 + 0009 0000", Code::E204, true),
        ("C15 + 0009 0000", "C15 + 0O09 0000", Code::E102, true),
        (">C00 0002", ">=C00 0003", Code::E201, true),
        (">C00 0002", "C00 > 0002", Code::E201, true),
    ];
    for (right, slip, code, fixed) in cases {
        let (pre, post) = if right.starts_with('>') {
            (right, "S***** #*01 + 0001 0000")
        } else {
            ("S*****", right)
        };
        let good = format!("r\n1\n{pre}\n{post} #*02 + 0001 0000\n");
        assert_eq!(codes(&run(&good, None, None)), [], "{good}");
        let bad = good.replacen(right, slip, 1);
        let c = run(&bad, None, None);
        assert_eq!(codes(&c), [code], "{bad}");
        assert_eq!(!c.diags[0].fixes.is_empty(), fixed, "{bad}");
        if fixed {
            let after = c.diags[0].fixes[0].apply(&bad, c.diags[0].primary.file);
            assert_eq!(codes(&run(&after, None, None)), [], "{after}");
        }
    }
    // A slot with the letter l for the digit 1.
    let slot = "r\n1\n=#N0l 0001\nS*****\n";
    let c = run(slot, None, None);
    assert_eq!(codes(&c), [Code::E306]);
    let after = c.diags[0].fixes[0].apply(slot, c.diags[0].primary.file);
    assert_eq!(after, "r\n1\n=#N01 0001\nS*****\n");
    let swapped = "fall\n1\nP0,-1 C00 - C00 0001\nN***0 >C00 0000\n";
    let c = run(swapped, None, None);
    assert_eq!(codes(&c), [Code::E322]);
    let after = c.diags[0].fixes[0].apply(swapped, c.diags[0].primary.file);
    assert_eq!(after, "fall\n1\nN***0 >C00 0000\nP0,-1 C00 - C00 0001\n");
}
