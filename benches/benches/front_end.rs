//! Front-end throughput on a generated rules file of 100,000 rules: the whole `check`
//! pipeline against two baselines measured in the same run, splitting the file into lines
//! and lexing every condition line.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use latticesim_benches::generate_rules;
use latticesim_grammar::lexer::Lexer;
use latticesim_grammar::lines::significant_lines;
use std::hint::black_box;

fn front_end(c: &mut Criterion) {
    let text = generate_rules(100_000, 1);
    let mut g = c.benchmark_group("check-100k-rules");
    g.throughput(Throughput::Bytes(text.len() as u64));
    g.sample_size(20);
    g.bench_function("baseline-lines", |b| {
        b.iter(|| significant_lines(black_box(&text)).count())
    });
    g.bench_function("baseline-lex", |b| {
        b.iter(|| {
            significant_lines(black_box(&text))
                .map(|l| Lexer::new(l.text, l.start, Some(2)).count())
                .sum::<usize>()
        })
    });
    g.bench_function("parse", |b| {
        b.iter(|| {
            let arena = bumpalo::Bump::new();
            let (f, d) = latticesim_grammar::parse_rules(
                black_box(&text),
                latticesim_grammar::FileId(0),
                &arena,
                Some(2),
            );
            (f.rules.len(), d.len())
        })
    });
    g.bench_function("check", |b| {
        b.iter(|| {
            let c = latticesim_compiler::check(
                latticesim_compiler::Input {
                    name: "gen.txt",
                    bytes: black_box(text.as_bytes()),
                },
                None,
                None,
            );
            assert_eq!(c.errors(), 0);
            c.rule_count
        })
    });
    g.finish();
}

criterion_group!(benches, front_end);
criterion_main!(benches);
