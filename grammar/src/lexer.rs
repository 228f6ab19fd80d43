//! The `logos` lexer for precondition and postcondition lines.
//!
//! Patterns with a fixed alphabet (`N1*0*`, `A**+*`, `P<=**`) and swap directions are one
//! token each, carrying their text; the checker judges the characters and lengths, so a wrong
//! one gets a precise message instead of a lexer error. State and message texts take
//! arbitrary printable characters, so `S`, `M` and the state of `T` read their five
//! characters in callbacks (see [`take_text`]). Offsets and numeric values are lexed finely
//! (letters, numbers, counters, commas) and assembled by the grammar.
//!
//! Blanks separate tokens and are skipped; the grammar checks that the pieces of one term
//! touch (so `E 1,0` is reported, not silently read).

use crate::lines::is_blank;
use logos::{Lexer as LogosLexer, Logos};

/// What the lexer knows of the dimension: it decides how `T1,0,0,ABCDE` splits.
#[derive(Debug, Clone, Copy, Default)]
pub struct LexExtras {
    /// The dimension, if known before parsing (2 or 3).
    pub dim_hint: Option<u8>,
    /// Byte offset where the state text of the current `T` term starts.
    state_at: Option<usize>,
}

/// A logos error: a character that starts no token.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LexError;

/// A character that starts no token, at absolute byte offsets `start..end`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BadChar {
    /// First byte.
    pub start: usize,
    /// One past the last byte.
    pub end: usize,
}

/// A message term `M` + direction + text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MsgTok<'a> {
    /// The direction character as written.
    pub dir: char,
    /// The text after it.
    pub text: &'a str,
}

/// Tokens of a precondition or postcondition line.
#[derive(Logos, Debug, Clone, Copy, PartialEq, Eq)]
#[logos(skip r"[ \t]+")]
#[logos(extras = LexExtras)]
#[logos(error = LexError)]
pub enum Tok<'a> {
    /// `!`
    #[token("!")]
    Bang,
    /// `(`
    #[token("(")]
    LParen,
    /// `)`
    #[token(")")]
    RParen,
    /// `,`
    #[token(",")]
    Comma,
    /// `<`
    #[token("<")]
    Lt,
    /// `>`
    #[token(">")]
    Gt,
    /// `=`
    #[token("=")]
    Eq,
    /// `+`
    #[token("+")]
    Plus,
    /// `-` (a blank follows; `-5` is a number)
    #[token("-")]
    Minus,
    /// `*`
    #[token("*")]
    Star,
    /// `/`
    #[token("/")]
    Slash,
    /// `M` standing alone: the modulo operator.
    #[token("M")]
    OpMod,
    /// `A` standing alone: the maximum operator.
    #[token("A")]
    OpMax,
    /// `I`: the minimum operator.
    #[token("I")]
    OpMin,
    /// `E` (empty position)
    #[token("E")]
    E,
    /// `F` (filled position)
    #[token("F")]
    F,
    /// `L` (smaller priority)
    #[token("L")]
    L,
    /// `Q` (smaller or equal priority)
    #[token("Q")]
    Q,
    /// `V` (remote counter strictly smaller)
    #[token("V")]
    V,
    /// `W` (remote counter smaller or equal)
    #[token("W")]
    W,
    /// `P` followed by an offset: a move.
    #[token("P")]
    P,
    /// `T`: remote state; its state text follows the offset.
    #[token("T", t_term)]
    T,
    /// `N` + pattern.
    #[regex(r"N[^ \t()]*", |lex| &lex.slice()[1..])]
    NPat(&'a str),
    /// `A` + pattern.
    #[regex(r"A[^ \t()]+", |lex| &lex.slice()[1..])]
    APat(&'a str),
    /// `P` + priority pattern (starts with `<`, `=` or `*`).
    #[regex(r"P[<=*][^ \t()]*", |lex| &lex.slice()[1..])]
    PPat(&'a str),
    /// `S` + state text.
    #[token("S", state_text)]
    SPat(&'a str),
    /// `M` + direction + text.
    #[regex(r"M[^ \t]", message)]
    Msg(MsgTok<'a>),
    /// `X` + direction.
    #[regex(r"X[^ \t()]*", |lex| &lex.slice()[1..])]
    Swap(&'a str),
    /// `C` + digits: a counter.
    #[regex(r"C[0-9]+", |lex| &lex.slice()[1..])]
    Counter(&'a str),
    /// `#` + direction + digits: a numeric message slot.
    #[regex(r"#[^ \t(),]*", |lex| &lex.slice()[1..])]
    MsgRef(&'a str),
    /// A whole number (saturated to the i64 range; the checker bounds it).
    #[regex(r"-?[0-9]+", int)]
    Int(i64),
    /// The five state characters of a `T` term (produced by [`Lexer`], not by logos).
    StateText(&'a str),
}

fn int<'a>(lex: &mut LogosLexer<'a, Tok<'a>>) -> i64 {
    let s = lex.slice();
    s.parse::<i64>().unwrap_or(if s.starts_with('-') {
        i64::MIN
    } else {
        i64::MAX
    })
}

/// The length in bytes of a state or message text at the start of `rest`.
///
/// A text is exactly five characters, but may contain `)`, and `)` may close a group right
/// after it. Take the run of non-blank characters; when it is longer than five and all that
/// follows the fifth character is `)`, those are closing parentheses; otherwise trailing `)`
/// beyond the fifth are parentheses too and the rest (of the wrong length) is the text, for
/// the checker to report.
pub fn take_text(rest: &str) -> usize {
    let run = rest.find(is_blank).unwrap_or(rest.len());
    let run_str = &rest[..run];
    let fifth = run_str
        .char_indices()
        .nth(5)
        .map(|(i, _)| i)
        .unwrap_or(run_str.len());
    if run_str[fifth..].bytes().all(|b| b == b')') {
        return fifth;
    }
    let trimmed = run_str.trim_end_matches(')');
    if trimmed.len() < fifth {
        fifth
    } else {
        trimmed.len()
    }
}

fn state_text<'a>(lex: &mut LogosLexer<'a, Tok<'a>>) -> &'a str {
    let rest = lex.remainder();
    let n = take_text(rest);
    lex.bump(n);
    &rest[..n]
}

fn message<'a>(lex: &mut LogosLexer<'a, Tok<'a>>) -> MsgTok<'a> {
    let dir = lex.slice()[1..].chars().next().unwrap_or('?');
    let rest = lex.remainder();
    let n = take_text(rest);
    lex.bump(n);
    MsgTok {
        dir,
        text: &rest[..n],
    }
}

/// Length of an offset component (`-12`, `7`, `C03`) at the start of `s`, if one is there.
fn component_len(s: &str) -> Option<usize> {
    let b = s.as_bytes();
    let digits_from = match b.first()? {
        b'-' | b'C' => 1,
        _ => 0,
    };
    let n = b[digits_from..]
        .iter()
        .take_while(|c| c.is_ascii_digit())
        .count();
    (n > 0).then_some(digits_from + n)
}

/// Where the state of a `T` term starts if its offset has `d` components: the byte offset
/// (relative to `rest`) after the comma that follows the last component, if the state text
/// found there is well formed.
fn t_split(rest: &str, d: usize, strict: bool) -> Option<usize> {
    let mut at = 0;
    for i in 0..d {
        if i > 0 {
            if !rest[at..].starts_with(',') {
                return None;
            }
            at += 1;
        }
        at += component_len(&rest[at..])?;
    }
    if !rest[at..].starts_with(',') {
        return None;
    }
    at += 1;
    if strict {
        let n = take_text(&rest[at..]);
        let text = &rest[at..at + n];
        let after = &rest[at + n..];
        let end = after.find(is_blank).unwrap_or(after.len());
        if text.chars().count() != 5 || !after[..end].bytes().all(|b| b == b')') {
            return None;
        }
    }
    Some(at)
}

fn t_term<'a>(lex: &mut LogosLexer<'a, Tok<'a>>) {
    let rest = lex.remainder();
    let order: &[usize] = match lex.extras.dim_hint {
        Some(3) => &[3, 2],
        Some(_) => &[2, 3],
        None => &[3, 2],
    };
    let found = order
        .iter()
        .find_map(|&d| t_split(rest, d, true))
        .or_else(|| order.iter().find_map(|&d| t_split(rest, d, false)));
    lex.extras.state_at = found.map(|at| lex.span().end + at);
}

/// The token stream handed to the parser: `(start, token, end)` triples with absolute byte
/// offsets in the file.
pub struct Lexer<'a> {
    inner: LogosLexer<'a, Tok<'a>>,
    base: usize,
}

impl<'a> Lexer<'a> {
    /// Lexes `line`, which starts at byte `base` of its file.
    pub fn new(line: &'a str, base: usize, dim_hint: Option<u8>) -> Lexer<'a> {
        let mut inner = Tok::lexer(line);
        inner.extras.dim_hint = dim_hint;
        Lexer { inner, base }
    }
}

/// A token with its absolute start and end.
pub type Spanned3<'a> = (usize, Tok<'a>, usize);

impl<'a> Iterator for Lexer<'a> {
    type Item = Result<Spanned3<'a>, BadChar>;

    fn next(&mut self) -> Option<Self::Item> {
        let pos = self.inner.span().end;
        if self.inner.extras.state_at == Some(pos) {
            self.inner.extras.state_at = None;
            let rest = self.inner.remainder();
            let n = take_text(rest);
            if n > 0 {
                self.inner.bump(n);
                let text = &rest[..n];
                return Some(Ok((
                    self.base + pos,
                    Tok::StateText(text),
                    self.base + pos + n,
                )));
            }
        }
        let tok = self.inner.next()?;
        let span = self.inner.span();
        let (start, end) = (self.base + span.start, self.base + span.end);
        Some(match tok {
            Ok(t) => Ok((start, t, end)),
            Err(LexError) => Err(BadChar { start, end }),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toks(s: &str, hint: Option<u8>) -> Vec<Tok<'_>> {
        Lexer::new(s, 0, hint).map(|r| r.unwrap().1).collect()
    }

    #[test]
    fn patterns_and_ops() {
        use Tok::*;
        assert_eq!(
            toks("!(N1*0* A**+*) P<=** SAB)CD) C00 A C00 #N01", None),
            vec![
                Bang,
                LParen,
                NPat("1*0*"),
                APat("**+*"),
                RParen,
                PPat("<=**"),
                SPat("AB)CD"),
                RParen,
                Counter("00"),
                OpMax,
                Counter("00"),
                MsgRef("N01")
            ]
        );
        assert_eq!(
            toks("C00 - C00 -0005 P-1,C03", None),
            vec![
                Counter("00"),
                Minus,
                Counter("00"),
                Int(-5),
                P,
                Int(-1),
                Comma,
                Counter("03")
            ]
        );
        assert_eq!(
            toks("M*HELLO) MN**", None),
            vec![
                Msg(MsgTok {
                    dir: '*',
                    text: "HELLO"
                }),
                RParen,
                Msg(MsgTok {
                    dir: 'N',
                    text: "**"
                })
            ]
        );
    }

    #[test]
    fn remote_state_splits_by_dimension() {
        use Tok::*;
        assert_eq!(
            toks("T1,0,0,ABC", None),
            vec![T, Int(1), Comma, Int(0), Comma, StateText("0,ABC")]
        );
        assert_eq!(
            toks("T1,0,0,ABCDE)", None),
            vec![
                T,
                Int(1),
                Comma,
                Int(0),
                Comma,
                Int(0),
                Comma,
                StateText("ABCDE"),
                RParen
            ]
        );
        assert_eq!(
            toks("T1,C02,12345", Some(2)),
            vec![T, Int(1), Comma, Counter("02"), Comma, StateText("12345")]
        );
    }

    #[test]
    fn text_lengths() {
        assert_eq!(take_text("ABCDE)) x"), 5);
        assert_eq!(take_text("ABCDEF)"), 6);
        assert_eq!(take_text("AB)"), 3);
        assert_eq!(take_text(""), 0);
    }
}
