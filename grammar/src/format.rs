//! The canonical layout of a rules file (`latticesim fmt`).
//!
//! Every rule is its four lines, with no blank line inside and one blank line before it
//! (before the comments just above it, which stay with it); each condition line is its
//! terms as [`crate::pretty`] prints them, one blank apart (numbers of comparisons and
//! calculations with four digits, as the paper writes them); a priority is its number.
//! Comments stay where they are, without indentation; a trailing comment follows its line
//! after one blank. Lines end in LF and the file in one. Formatting a formatted file
//! changes nothing, and the formatted file parses to the same rules.

use crate::ast::Rule;
use crate::diag::Diagnostic;
use crate::span::FileId;
use bumpalo::Bump;

/// What one line of the source is.
enum Item {
    Blank,
    Comment(String),
    /// A line of a rule: which part (0 name, 1 priority, 2 precondition, 3 postcondition)
    /// and its canonical text (with its trailing comment).
    Part(u8, String),
}

/// The canonical text of a line of a rule, by the byte where its text starts.
fn parts(rules: &[Rule<'_>]) -> Vec<(u32, u8, String)> {
    let mut out = Vec::with_capacity(rules.len() * 4);
    let terms = |ts: &[crate::span::Spanned<crate::ast::Term<'_>>]| {
        ts.iter()
            .map(|t| t.node.to_string())
            .collect::<Vec<_>>()
            .join(" ")
    };
    for r in rules {
        out.push((r.name.span.start, 0, r.name.node.to_string()));
        let p = r.priority.node.map_or(String::new(), |p| p.to_string());
        out.push((r.priority.span.start, 1, p));
        out.push((r.pre.span.start, 2, terms(r.pre.node)));
        out.push((r.post.span.start, 3, terms(r.post.node)));
    }
    out.sort_by_key(|p| p.0);
    out
}

/// The canonical layout of `src`, or the errors that keep it from being read (a file with
/// syntax errors is not formatted; the checker's other errors do not matter here).
pub fn format_rules(src: &str, dim_hint: Option<u8>) -> Result<String, Vec<Diagnostic>> {
    let arena = Bump::new();
    let (ast, diags) = crate::parse_rules(src, FileId(0), &arena, dim_hint);
    let errors: Vec<Diagnostic> = diags.into_iter().filter(|d| d.is_error()).collect();
    if !errors.is_empty() {
        return Err(errors);
    }
    let parts = parts(&ast.rules);
    let mut items = Vec::new();
    let mut offset = 0usize;
    for raw in src.split_inclusive('\n') {
        let start = offset;
        offset += raw.len();
        let body = raw.trim_end_matches(['\n', '\r']);
        let (code, comment) = match body.find("//") {
            Some(c) => (&body[..c], Some(body[c..].trim_end())),
            None => (body, None),
        };
        let lead = code.len() - code.trim_start_matches(crate::lines::is_blank).len();
        let code = code.trim_matches(crate::lines::is_blank);
        if code.is_empty() {
            items.push(match comment {
                Some(c) => Item::Comment(c.to_string()),
                None => Item::Blank,
            });
            continue;
        }
        let at = (start + lead) as u32;
        let (role, text) = match parts.binary_search_by_key(&at, |p| p.0) {
            Ok(i) => (parts[i].1, parts[i].2.clone()),
            // Every significant line of a file without errors is a line of a rule.
            Err(_) => (0, code.to_string()),
        };
        let text = match comment {
            Some(c) => format!("{text} {c}"),
            None => text,
        };
        items.push(Item::Part(role, text));
    }
    Ok(layout(items))
}

/// Paragraphs: a rule with the comments just above it, or comments alone.
fn layout(items: Vec<Item>) -> String {
    let mut paras: Vec<Vec<Item>> = vec![Vec::new()];
    for item in items {
        let many = paras.len() > 1;
        let cur = paras.last_mut().expect("never empty");
        let has_part = cur.iter().any(|i| matches!(i, Item::Part(..)));
        match item {
            Item::Blank => {
                if !cur.is_empty() {
                    paras.push(Vec::new());
                }
            }
            Item::Part(0, _) if has_part => {
                // A rule right after another: it starts its own paragraph, taking the
                // comments between them.
                let split = cur
                    .iter()
                    .rposition(|i| matches!(i, Item::Part(..)))
                    .map_or(0, |p| p + 1);
                let moved: Vec<Item> = cur.drain(split..).collect();
                paras.push(moved);
                paras.last_mut().expect("pushed").push(item);
            }
            Item::Part(role, _) if role > 0 && !has_part && many => {
                // A blank line inside a rule: this paragraph goes on the previous one.
                let cur = paras.pop().expect("more than one");
                let prev = paras.last_mut().expect("more than one");
                prev.extend(cur);
                prev.push(item);
            }
            _ => cur.push(item),
        }
    }
    let mut out = String::new();
    for p in paras.iter().filter(|p| !p.is_empty()) {
        if !out.is_empty() {
            out.push('\n');
        }
        for i in p {
            match i {
                Item::Comment(t) | Item::Part(_, t) => out += t,
                Item::Blank => {}
            }
            out.push('\n');
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn canonical_layout_keeps_comments() {
        let src = "// head\r\n\r\n\r\n  // about a\r\na   \r\n\r\n007\r\n  N1*** >C00 5   // why\r\nC00 + 1 0  \r\nb\n1\nS*****\nS*****\n// tail\n\n\n";
        let want = "// head\n\n// about a\na\n7\nN1*** >C00 0005 // why\nC00 + 0001 0000\n\nb\n1\nS*****\nS*****\n// tail\n";
        assert_eq!(format_rules(src, None).unwrap(), want);
        assert_eq!(format_rules(want, None).unwrap(), want);
    }

    #[test]
    fn files_with_syntax_errors_are_not_formatted() {
        assert!(format_rules("a\n1\nE1,\nS*****\n", None).is_err());
        // A rule's other errors (a wrong length) do not keep it from being formatted.
        assert!(format_rules("a\n1\nN1*\nS*****\n", None).is_ok());
    }
}
