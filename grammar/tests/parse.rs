use bumpalo::Bump;
use latticesim_grammar::{parse_rules, Code, FileId};

fn codes(src: &str) -> Vec<Code> {
    let arena = Bump::new();
    let (_, d) = parse_rules(src, FileId(0), &arena, None);
    d.iter().map(|d| d.code).collect()
}

#[test]
fn paper_examples_parse() {
    let src = "flood\n1\nS*****\nC00 A C00 #N01 C00 A C00 #W01 C00 A C00 #E01 C00 A C00 #S01 #*01 + C00 0000\n\
               fall\n1\nN***0 >C00 0000\nP0,-1 C00 - C00 0001\n\
               all\n32767\n!(N1*** N*1**) E-1,C03 F1,0 P<=** L0,1 Q1,1 A1*0* T1,0,AB)DE MNab*de V1,0,C03 0010 W-1,0,C04 #*01 =#N01 -0005\n\
               S**A** MEhello XN C00 + 1,0,C03 0001 #S02 I C01,C02,C05 C04 A1+*0\n";
    let arena = Bump::new();
    let (f, d) = parse_rules(src, FileId(0), &arena, None);
    assert!(d.is_empty(), "{d:#?}");
    assert_eq!(f.rules.len(), 3);
    assert_eq!(f.rules[2].pre.node.len(), 12);
    assert_eq!(f.rules[2].post.node.len(), 6);
    let printed = f.to_string();
    let arena2 = Bump::new();
    let (g, d2) = parse_rules(&printed, FileId(0), &arena2, None);
    assert!(d2.is_empty(), "{printed}\n{d2:#?}");
    assert_eq!(f, g, "{printed}");
}

#[test]
fn syntax_errors_are_all_reported() {
    assert_eq!(codes("r\n1\nE 1,0 N1***\nS*****\n"), vec![Code::E204]);
    assert_eq!(
        codes("r\n1\n(N1*** ?\nS*****\n"),
        vec![Code::E203, Code::E102]
    );
    assert_eq!(codes("r\n1\nE1, N1***\nS*****\n"), vec![Code::E201]);
    assert_eq!(codes("r\n1\nN1*** E\nS*****\n"), vec![Code::E202]);
    assert_eq!(
        codes("r\nx\nN1***\nS*****\nq\n1\n"),
        vec![Code::E205, Code::E103]
    );
    assert_eq!(
        codes("r\n1\nE1, N1*** <C00 ) F2,\nS*****\n"),
        vec![Code::E201, Code::E201, Code::E201, Code::E202]
    );
    // One slip, one error: the rest of a broken term is not read as terms of its own.
    assert_eq!(
        codes("r\n1\nS*****\nC00 = 0 #*01 + C00 0000\n"),
        vec![Code::E201]
    );
    assert_eq!(
        codes("r\n1\nS*****\nC00 = C01 0000 SABCDE\n"),
        vec![Code::E201]
    );
    assert_eq!(codes("r\n1\nsDONE0\nS*****\n"), vec![Code::E102]);
    // `C00 = 5`: a calculation in a postcondition, a comparison in a precondition.
    let fix = |src: &str| {
        let arena = Bump::new();
        let (_, d) = parse_rules(src, FileId(0), &arena, None);
        d[0].fixes[0].apply(src, FileId(0))
    };
    assert_eq!(
        fix("r\n1\nS*****\nC00 = 5\n"),
        "r\n1\nS*****\nC00 + 5 0000\n"
    );
    assert_eq!(fix("r\n1\nC00 = 5\nS*****\n"), "r\n1\n=C00 5\nS*****\n");
    assert_eq!(codes("r\n1\nF1.0 N1***\nS*****\n"), vec![Code::E102]);
    assert_eq!(codes("r\n1\n!Z1,0\nS*****\n"), vec![Code::E102]);
    assert_eq!(codes("r\n1\n<C00 00x0 E1,0\nS*****\n"), vec![Code::E102]);
}
