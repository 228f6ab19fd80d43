//! The rule structure of rules.txt, found from the shape of the file before any term is read.
//!
//! A rule is four significant lines: name, priority, precondition, postcondition. Rules are
//! usually separated by blank lines, and a priority is a line of digits. So the file is cut
//! into blocks at blank lines (a block that is not a whole number of rules is joined to the
//! next when together they are, so a blank line inside a rule still reads as before); a
//! block of 4k lines is k rules; any other block is cut at its priority lines, each rule
//! starting on the line before one. A rule with too few or too many lines is then reported
//! once, on that rule, naming the line it lacks or the lines it has too many; its neighbours
//! are read as they were written.

use crate::lines::Line;

/// One rule as laid out in the file: which significant lines play which part.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout<'a> {
    /// The name line, if the rule has one.
    pub name: Option<Line<'a>>,
    /// The priority line, if the rule has one.
    pub priority: Option<Line<'a>>,
    /// The precondition line, if any.
    pub pre: Option<Line<'a>>,
    /// The postcondition line, if any.
    pub post: Option<Line<'a>>,
    /// Lines after the postcondition that belong to no rule (the first and the last).
    pub extra: Option<(Line<'a>, Line<'a>)>,
}

impl<'a> Layout<'a> {
    /// The lines the rule has, in file order.
    pub fn lines(&self) -> impl Iterator<Item = Line<'a>> {
        [self.name, self.priority, self.pre, self.post]
            .into_iter()
            .flatten()
    }

    /// True when the rule has all four lines and no more.
    pub fn is_whole(&self) -> bool {
        self.name.is_some()
            && self.priority.is_some()
            && self.pre.is_some()
            && self.post.is_some()
            && self.extra.is_none()
    }
}

/// True for a line that reads as a priority: an optional sign and digits.
pub fn is_priority(text: &str) -> bool {
    let digits = text.strip_prefix(['-', '+']).unwrap_or(text);
    !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit())
}

/// Which of the two condition lines a lone one is: false for a precondition. A line is a
/// postcondition when its first term is an action only a postcondition has (a calculation,
/// a move, a swap), or when it has such an action and no term only a precondition has.
fn looks_like_post(text: &str) -> bool {
    let mut pre_only = false;
    let mut post_only = false;
    for word in text.split(crate::lines::is_blank).filter(|w| !w.is_empty()) {
        let w = word.trim_start_matches(['!', '(']);
        let post = match w.as_bytes() {
            [b'C' | b'#', ..] => true,
            [b'X', ..] => true,
            [b'P', c, ..] => c.is_ascii_digit() || matches!(c, b'-' | b'C'),
            _ => false,
        };
        let pre = word.starts_with(['!', '('])
            || matches!(
                w.as_bytes(),
                [
                    b'N' | b'E' | b'F' | b'L' | b'Q' | b'T' | b'V' | b'W' | b'<' | b'>' | b'=',
                    ..
                ] | [b'P', b'<' | b'=' | b'*', ..]
            );
        if !pre_only && !post_only && post {
            return true;
        }
        pre_only |= pre;
        post_only |= post;
    }
    post_only && !pre_only
}

/// How many lines of a block without blank lines are held before its whole rules are cut.
const CLEAN_RUN: usize = 4096;

/// The rules of a file's significant lines, in order.
pub fn layouts<'a>(lines: &[Line<'a>]) -> Vec<Layout<'a>> {
    let mut out = Vec::with_capacity(lines.len() / 4 + 1);
    for_each(lines.iter().copied(), |l| out.push(l));
    out
}

/// Calls `f` with each rule of a file's significant lines, in order, holding only a block
/// or two of lines at a time (a large file's lines are never all kept).
pub fn for_each<'a>(lines: impl Iterator<Item = Line<'a>>, mut f: impl FnMut(Layout<'a>)) {
    // `pending`: a block that is not whole rules, kept to be joined to the next when
    // together they are (a blank line inside a rule). `cur`: the block being read.
    let mut pending: Vec<Line<'a>> = Vec::new();
    let mut cur: Vec<Line<'a>> = Vec::new();
    let mut out = Vec::new();
    for line in lines {
        if line.after_blank && !cur.is_empty() {
            finish(&mut pending, &mut cur, &mut out);
            out.drain(..).for_each(&mut f);
        }
        cur.push(line);
        // A long block without blank lines: its whole rules so far (priorities on every
        // fourth line and nowhere else) are cut as they come, but for the last two, which a
        // missing or extra line further on may still concern.
        if pending.is_empty() && cur.len() >= CLEAN_RUN + 8 && cur.len().is_multiple_of(4) {
            let done = cur.len() - 8;
            let clean = cur[..done]
                .iter()
                .enumerate()
                .all(|(i, l)| is_priority(l.text) == (i % 4 == 1));
            if clean {
                cur[..done].chunks_exact(4).map(whole).for_each(&mut f);
                cur.drain(..done);
            }
        }
    }
    finish(&mut pending, &mut cur, &mut out);
    finish(&mut pending, &mut cur, &mut out);
    out.into_iter().for_each(f);
}

/// Cuts the blocks read so far into rules: `pending` joined to `cur` when together they
/// are whole rules, else alone; `cur` kept as the next `pending` when it is not whole rules.
fn finish<'a>(pending: &mut Vec<Line<'a>>, cur: &mut Vec<Line<'a>>, out: &mut Vec<Layout<'a>>) {
    if !pending.is_empty() {
        let alone = pending.len();
        pending.extend(cur.iter().copied());
        if pending.len().is_multiple_of(4) && priorities_every_fourth(pending) {
            cur.clear();
        } else {
            pending.truncate(alone);
        }
        block(pending, out);
        pending.clear();
    }
    if !cur.is_empty() {
        if cur.len().is_multiple_of(4) {
            block(cur, out);
            cur.clear();
        } else {
            std::mem::swap(pending, cur);
        }
    }
}

fn priorities_every_fourth(lines: &[Line<'_>]) -> bool {
    lines.iter().skip(1).step_by(4).all(|l| is_priority(l.text))
}

fn whole<'a>(chunk: &[Line<'a>]) -> Layout<'a> {
    Layout {
        name: Some(chunk[0]),
        priority: Some(chunk[1]),
        pre: Some(chunk[2]),
        post: Some(chunk[3]),
        extra: None,
    }
}

/// Cuts one block into rules.
fn block<'a>(lines: &[Line<'a>], out: &mut Vec<Layout<'a>>) {
    if lines.len().is_multiple_of(4) {
        out.extend(lines.chunks_exact(4).map(whole));
        return;
    }
    // Rules start on the line before each priority line (a rule may be named by digits: a
    // priority line right after a start is that rule's priority, not another start).
    let mut starts = Vec::new();
    let mut i = 0;
    while i + 1 < lines.len() {
        let numbered_name = lines.get(i + 2).is_some_and(|l| is_priority(l.text));
        if is_priority(lines[i + 1].text)
            && !numbered_name
            && starts.last().is_none_or(|&s| i >= s + 2)
        {
            starts.push(i);
            i += 2;
        } else {
            i += 1;
        }
    }
    if starts.is_empty() {
        // No priority to go by: whole rules of four lines, the rest a rule that lacks its
        // priority (when its second line reads as a condition) or is cut short.
        let whole_rules = lines.len() / 4 * 4;
        out.extend(lines[..whole_rules].chunks_exact(4).map(whole));
        let rest = &lines[whole_rules..];
        match rest {
            [first, ..] if is_priority(first.text) => {
                out.push(conditions(None, Some(*first), &rest[1..]))
            }
            [name, second, ..]
                if !second
                    .text
                    .starts_with(|c: char| c.is_ascii_digit() || c == '-' || c == '+') =>
            {
                out.push(conditions(Some(*name), None, &rest[1..]))
            }
            _ => out.push(partial(rest)),
        }
        return;
    }
    if starts[0] > 0 {
        // Lines before the first rule's name: a rule that lacks its name (its priority
        // comes first) or lines that belong to none.
        let head = &lines[..starts[0]];
        if is_priority(head[0].text) {
            let mut l = conditions(None, Some(head[0]), &head[1..]);
            l.name = None;
            out.push(l);
        } else {
            out.push(partial(head));
        }
    }
    for (k, &s) in starts.iter().enumerate() {
        let e = starts.get(k + 1).copied().unwrap_or(lines.len());
        let seg = &lines[s..e];
        if seg.len() > 4 && seg.len().is_multiple_of(4) {
            // Whole rules whose priority lines are not numbers (reported as such).
            out.extend(seg.chunks_exact(4).map(whole));
        } else {
            out.push(conditions(Some(seg[0]), Some(seg[1]), &seg[2..]));
        }
    }
}

/// A rule from its name and priority (when present) and the condition lines after them.
fn conditions<'a>(
    name: Option<Line<'a>>,
    priority: Option<Line<'a>>,
    conds: &[Line<'a>],
) -> Layout<'a> {
    let mut l = Layout {
        name,
        priority,
        pre: None,
        post: None,
        extra: None,
    };
    match conds {
        [] => {}
        [one] if looks_like_post(one.text) => l.post = Some(*one),
        [one] => l.pre = Some(*one),
        [pre, post, rest @ ..] => {
            l.pre = Some(*pre);
            l.post = Some(*post);
            if let (Some(a), Some(b)) = (rest.first(), rest.last()) {
                l.extra = Some((*a, *b));
            }
        }
    }
    l
}

/// A rule of fewer than four lines with no priority line among them: the lines are taken
/// in order (name, priority, precondition) as far as they go.
fn partial<'a>(lines: &[Line<'a>]) -> Layout<'a> {
    Layout {
        name: lines.first().copied(),
        priority: lines.get(1).copied(),
        pre: lines.get(2).copied(),
        post: lines.get(3).copied(),
        extra: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lines::significant_lines;

    fn shape(src: &str) -> Vec<String> {
        let lines: Vec<Line<'_>> = significant_lines(src).collect();
        layouts(&lines)
            .iter()
            .map(|l| {
                let part = |x: Option<Line<'_>>| x.map_or("-".to_string(), |l| l.text.to_string());
                let mut s = format!(
                    "{} {} {} {}",
                    part(l.name),
                    part(l.priority),
                    part(l.pre),
                    part(l.post)
                );
                if let Some((a, b)) = l.extra {
                    s += &format!(" +{}..{}", a.number, b.number);
                }
                s
            })
            .collect()
    }

    #[test]
    fn whole_rules_with_and_without_blank_lines() {
        let src = "a\n1\nN1***\nSX****\n\nb\n2\nE1,0\nP1,0\nc\n3\nSX****\nSY****\n";
        assert_eq!(
            shape(src),
            ["a 1 N1*** SX****", "b 2 E1,0 P1,0", "c 3 SX**** SY****"]
        );
        // A blank line inside a rule.
        assert_eq!(shape("a\n\n1\nN1***\nSX****\n"), ["a 1 N1*** SX****"]);
        // Priorities that are not numbers, in whole blocks.
        assert_eq!(shape("a\nx\nN1***\nSX****\n"), ["a x N1*** SX****"]);
    }

    #[test]
    fn a_missing_line_is_found_on_its_rule() {
        // The postcondition of `a` is missing; `b` is read whole.
        let src = "a\n1\nN1***\nb\n2\nE1,0\nP1,0\n";
        assert_eq!(shape(src), ["a 1 N1*** -", "b 2 E1,0 P1,0"]);
        // A lone calculation is a postcondition: the precondition is missing.
        let src = "a\n1\nC00 + C00 0001\n\nb\n2\nE1,0\nP1,0\n";
        assert_eq!(shape(src), ["a 1 - C00 + C00 0001", "b 2 E1,0 P1,0"]);
        // The priority is missing.
        let src = "a\nN1***\nSX****\n\nb\n2\nE1,0\nP1,0\n";
        assert_eq!(shape(src), ["a - N1*** SX****", "b 2 E1,0 P1,0"]);
        // A priority that is not a number, in a rule that lacks a line.
        assert_eq!(shape("a\n1x\nN1***\n"), ["a 1x N1*** -"]);
        // The name is missing.
        let src = "x\n1\nS*****\nS*****\n\n2\nE1,0\nP1,0\n";
        assert_eq!(shape(src), ["x 1 S***** S*****", "- 2 E1,0 P1,0"]);
        // A line too many.
        let src = "a\n1\nN1***\nSX****\nSY****\nb\n2\nE1,0\nP1,0\n";
        assert_eq!(shape(src), ["a 1 N1*** SX**** +5..5", "b 2 E1,0 P1,0"]);
        // A long file without blank lines, cut as it is read: a slip far in, and one early.
        for lost in [2500usize, 10] {
            let mut src = String::new();
            for i in 0..3000 {
                src += &format!("r{i}\n{}\nN1***\n", 1 + i % 7);
                if i != lost {
                    src += "SX****\n";
                }
            }
            let got = shape(&src);
            assert_eq!(got.len(), 3000);
            for (i, g) in got.iter().enumerate() {
                let want = format!(
                    "r{i} {} N1*** {}",
                    1 + i % 7,
                    if i == lost { "-" } else { "SX****" }
                );
                assert_eq!(g, &want, "rule {i} of the file losing {lost}");
            }
        }
        // Rules named by numbers.
        assert_eq!(
            shape("7\n1\nS*****\nS*****\n8\n2\nS*****\n"),
            ["7 1 S***** S*****", "8 2 S***** -"]
        );
    }
}
