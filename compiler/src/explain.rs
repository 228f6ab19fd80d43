//! The long explanation of every diagnostic code, from one source: `explain.md` beside this
//! file. `latticesim explain CODE` prints a section with the diagnostic its wrong example
//! really gives; the reference in docs/language.md is generated from the same sections
//! ([`markdown`]); a test checks every code has one, that the wrong example gives its code
//! and that the right one checks clean.

use crate::{check, Checked, Dim, Input};
use latticesim_grammar::Code;

const SOURCE: &str = include_str!("explain.md");

/// An example: its files (name, text as written in the source) and `--dim`, if given.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Example {
    /// `rules.txt` first, then `agents.txt` if the example has one; the text as written
    /// (see [`expand`] for the bytes it stands for).
    pub files: Vec<(String, String)>,
    /// `--dim`, when the example is checked with it.
    pub dim: Option<Dim>,
}

impl Example {
    /// Checks the example as `latticesim check` would.
    pub fn check(&self) -> Checked {
        let bytes: Vec<(&str, Vec<u8>)> = self
            .files
            .iter()
            .map(|(n, t)| (n.as_str(), expand(t)))
            .collect();
        let input = |i: usize| {
            bytes.get(i).map(|(name, b)| Input {
                name,
                bytes: b.as_slice(),
            })
        };
        check(
            input(0).expect("an example has a rules file"),
            input(1),
            self.dim,
        )
    }
}

/// One code's section.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Explanation {
    /// The code.
    pub code: Code,
    /// What it means and why it is reported (Markdown paragraphs).
    pub text: String,
    /// An example that gives the code.
    pub wrong: Example,
    /// The same example put right.
    pub right: Example,
}

/// The bytes an example's text stands for: `\xNN` is the byte NN and `⟪N×text⟫` is `text`
/// written N times.
pub fn expand(text: &str) -> Vec<u8> {
    let mut out = Vec::with_capacity(text.len());
    let mut rest = text;
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix("\\x") {
            if let Some(b) = r.get(..2).and_then(|h| u8::from_str_radix(h, 16).ok()) {
                out.push(b);
                rest = &r[2..];
                continue;
            }
        }
        if let Some(r) = rest.strip_prefix('⟪') {
            if let Some((inner, after)) = r.split_once('⟫') {
                if let Some((n, t)) = inner.split_once('×') {
                    if let Ok(n) = n.parse::<usize>() {
                        out.extend(t.as_bytes().repeat(n));
                        rest = after;
                        continue;
                    }
                }
            }
        }
        let c = rest.chars().next().expect("not empty");
        let mut buf = [0; 4];
        out.extend(c.encode_utf8(&mut buf).as_bytes());
        rest = &rest[c.len_utf8()..];
    }
    out
}

fn example(part: &str) -> Example {
    let dim = part.lines().find_map(|l| {
        let n = l.strip_prefix("Checked with `--dim ")?.strip_suffix("`.")?;
        match n {
            "2" => Some(Dim::Two),
            "3" => Some(Dim::Three),
            _ => None,
        }
    });
    let mut files = Vec::new();
    let mut lines = part.lines();
    while let Some(l) = lines.next() {
        let Some(name) = l.strip_prefix('`').and_then(|r| r.strip_suffix("`:")) else {
            continue;
        };
        let mut text = String::new();
        let mut inside = false;
        for l in lines.by_ref() {
            if l.starts_with("```") {
                if inside {
                    break;
                }
                inside = true;
            } else if inside {
                text += l;
                text.push('\n');
            }
        }
        files.push((name.to_string(), text));
    }
    Example { files, dim }
}

/// Every section of the source, in its order.
pub fn all() -> Vec<Explanation> {
    SOURCE
        .split("\n## ")
        .skip(1)
        .filter_map(|section| {
            let (head, body) = section.split_once('\n')?;
            let code = Code::parse(head.split_whitespace().next()?)?;
            let (text, examples) = body.split_once("\n### Wrong\n")?;
            let (wrong, right) = examples.split_once("\n### Right\n")?;
            Some(Explanation {
                code,
                text: text.trim().to_string(),
                wrong: example(wrong),
                right: example(right),
            })
        })
        .collect()
}

/// The section of one code.
pub fn explanation(code: Code) -> Option<Explanation> {
    all().into_iter().find(|e| e.code == code)
}

/// The code nearest to what was typed (`e302`, `302`, `E32`), for a message.
pub fn nearest(typed: &str) -> Option<Code> {
    let t = typed.trim().to_ascii_uppercase();
    if let Some(c) = Code::parse(&t) {
        return Some(c);
    }
    let digits: String = t.chars().filter(|c| c.is_ascii_digit()).collect();
    Code::ALL
        .iter()
        .copied()
        .find(|c| c.as_str()[1..] == digits)
        .or_else(|| Code::ALL.iter().copied().find(|c| c.slug() == typed.trim()))
}

fn indented(text: &str) -> String {
    text.lines()
        .map(|l| {
            if l.is_empty() {
                "\n".to_string()
            } else {
                format!("    {l}\n")
            }
        })
        .collect()
}

fn files_of(e: &Example) -> String {
    let mut out = String::new();
    if let Some(d) = e.dim {
        out += &format!("checked with `--dim {}`\n", d.coords());
    }
    for (name, text) in &e.files {
        out += &format!("{name}:\n{}", indented(text));
    }
    out
}

/// The section as `latticesim explain` prints it: the text, the wrong example and what it
/// gives (rendered in colour when `color`), the right example.
pub fn render(e: &Explanation, color: bool) -> String {
    let c = e.wrong.check();
    format!(
        "{} {}: {}\n\n{}\n\nWrong:\n{}\ngives:\n\n{}\nRight:\n{}",
        e.code.as_str(),
        e.code.slug(),
        e.code.title(),
        e.text,
        files_of(&e.wrong),
        c.render(color),
        files_of(&e.right)
    )
}

/// Lines longer than 120 characters, shown cut with their length (for the docs).
fn shorten(text: &str) -> String {
    text.lines()
        .map(|l| {
            let n = l.chars().count();
            if n > 120 {
                let head: String = l.chars().take(100).collect();
                format!("{head}… ({n} characters in all)\n")
            } else {
                format!("{l}\n")
            }
        })
        .collect()
}

fn md_files(e: &Example, what: &str) -> String {
    let mut out = what.to_string();
    if let Some(d) = e.dim {
        out += &format!(", checked with `--dim {}`", d.coords());
    }
    out += ":\n\n";
    for (name, text) in &e.files {
        out += &format!("`{name}`:\n\n```\n{}```\n\n", shorten(text));
    }
    out
}

/// The section as docs/language.md shows it.
pub fn markdown(e: &Explanation) -> String {
    let c = e.wrong.check();
    let out = crate::diagnostics::render_plain(&c.diags, &c.sources);
    format!(
        "### {} {}\n\n{}\n\n{}```\n{}\n```\n\n{}",
        e.code.as_str(),
        e.code.slug(),
        e.text,
        md_files(&e.wrong, "Wrong"),
        shorten(&out).trim_end(),
        md_files(&e.right, "Right")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expands_bytes_and_repeats() {
        assert_eq!(expand("S\\xff*"), b"S\xff*");
        assert_eq!(expand("⟪3×!⟫S"), b"!!!S");
        assert_eq!(expand("⟪x×!⟫"), "⟪x×!⟫".as_bytes());
    }

    #[test]
    fn nearest_codes() {
        assert_eq!(nearest("e302"), Some(Code::E302));
        assert_eq!(nearest("302"), Some(Code::E302));
        assert_eq!(nearest("pattern-length"), Some(Code::E302));
        assert_eq!(nearest("E999"), None);
    }

    /// Every code has a section; its wrong example gives that code and its right example
    /// checks clean.
    #[test]
    fn every_code_is_explained_with_examples_that_hold() {
        let all = all();
        let mut problems = Vec::new();
        for &code in Code::ALL {
            let Some(e) = all.iter().find(|e| e.code == code) else {
                problems.push(format!("{}: no section in explain.md", code.as_str()));
                continue;
            };
            if e.text.len() < 40 {
                problems.push(format!("{}: the explanation is too short", code.as_str()));
            }
            let wrong = e.wrong.check();
            if !wrong.diags.iter().any(|d| d.code == code) {
                problems.push(format!(
                    "{}: the wrong example does not give it:\n{}",
                    code.as_str(),
                    wrong.render(false)
                ));
            }
            let right = e.right.check();
            if right.errors() + right.warnings() > 0 {
                problems.push(format!(
                    "{}: the right example does not check clean:\n{}",
                    code.as_str(),
                    right.render(false)
                ));
            }
        }
        let codes: Vec<Code> = all.iter().map(|e| e.code).collect();
        let mut sorted = codes.clone();
        sorted.sort();
        sorted.dedup();
        assert_eq!(codes.len(), sorted.len(), "a code explained twice");
        assert!(problems.is_empty(), "{}", problems.join("\n\n"));
    }
}
