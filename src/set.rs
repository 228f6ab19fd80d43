//! `sweep --set Cnn=EXPR`: a counter of every agent set from an integer expression over
//! the agent and the run: `n` (agents), `x`, `y`, `z` (its position), `id` (its 0-based
//! line in the agents file) and `seed`, with numbers, `+ - * / %` (integer division and
//! remainder, truncated toward zero, as the rules' `/` and `M`), unary minus and
//! parentheses; e.g. `C00=id+1`, `C01=n`, `C02=(x+y)%2`.
//!
//! Written here because the expression crates at hand either compute in floating point
//! (`meval`, `fasteval`: `n/2` would not be integer division) or carry a licence this
//! project cannot take (`evalexpr`, AGPL).

use latticesim_runtime::Lattice;

/// The names an expression may use, in the order of [`Vars`].
const NAMES: [&str; 6] = ["n", "x", "y", "z", "id", "seed"];

/// The values of [`NAMES`] for one agent.
pub(crate) type Vars = [i64; 6];

#[derive(Debug, Clone, PartialEq)]
enum Expr {
    Num(i64),
    Var(usize),
    Neg(Box<Expr>),
    Bin(u8, Box<Expr>, Box<Expr>),
}

/// One `--set`: the counter and its expression (as written, for messages).
#[derive(Debug, Clone)]
pub struct Setting {
    counter: u8,
    expr: Expr,
    text: String,
}

impl std::str::FromStr for Setting {
    type Err = String;

    fn from_str(s: &str) -> Result<Setting, String> {
        let (lhs, rhs) = s.split_once('=').ok_or_else(|| {
            format!("`{s}`: write a counter, `=` and an expression, e.g. C00=id+1")
        })?;
        let counter = crate::gen::parse_counter(lhs.trim())?;
        let mut p = Parser {
            s: rhs.as_bytes(),
            at: 0,
        };
        let expr = p.sum()?;
        p.blanks();
        if p.at < p.s.len() {
            return Err(p.expected("an operator (+ - * / %) or the end"));
        }
        Ok(Setting {
            counter,
            expr,
            text: s.to_string(),
        })
    }
}

struct Parser<'a> {
    s: &'a [u8],
    at: usize,
}

impl Parser<'_> {
    fn blanks(&mut self) {
        while self.s.get(self.at).is_some_and(u8::is_ascii_whitespace) {
            self.at += 1;
        }
    }

    fn expected(&self, what: &str) -> String {
        let found = match self.s.get(self.at) {
            Some(_) => format!(
                "`{}`",
                String::from_utf8_lossy(&self.s[self.at..])
                    .chars()
                    .next()
                    .unwrap_or('?')
            ),
            None => "the end".into(),
        };
        format!(
            "expected {what} at character {} of the expression, found {found}",
            self.at + 1
        )
    }

    /// A sum of products.
    fn sum(&mut self) -> Result<Expr, String> {
        let mut e = self.product()?;
        loop {
            self.blanks();
            match self.s.get(self.at) {
                Some(&op @ (b'+' | b'-')) => {
                    self.at += 1;
                    e = Expr::Bin(op, Box::new(e), Box::new(self.product()?));
                }
                _ => return Ok(e),
            }
        }
    }

    /// A product of factors.
    fn product(&mut self) -> Result<Expr, String> {
        let mut e = self.factor()?;
        loop {
            self.blanks();
            match self.s.get(self.at) {
                Some(&op @ (b'*' | b'/' | b'%')) => {
                    self.at += 1;
                    e = Expr::Bin(op, Box::new(e), Box::new(self.factor()?));
                }
                _ => return Ok(e),
            }
        }
    }

    /// A number, a name, a negated factor or a sum in parentheses.
    fn factor(&mut self) -> Result<Expr, String> {
        self.blanks();
        let start = self.at;
        match self.s.get(self.at) {
            Some(b'-') => {
                self.at += 1;
                Ok(Expr::Neg(Box::new(self.factor()?)))
            }
            Some(b'(') => {
                self.at += 1;
                let e = self.sum()?;
                self.blanks();
                if self.s.get(self.at) != Some(&b')') {
                    return Err(self.expected("`)`"));
                }
                self.at += 1;
                Ok(e)
            }
            Some(b) if b.is_ascii_digit() => {
                while self.s.get(self.at).is_some_and(u8::is_ascii_digit) {
                    self.at += 1;
                }
                let digits = std::str::from_utf8(&self.s[start..self.at]).expect("digits");
                digits
                    .parse()
                    .map(Expr::Num)
                    .map_err(|_| format!("the number {digits} is too large"))
            }
            Some(b) if b.is_ascii_alphabetic() => {
                while self.s.get(self.at).is_some_and(u8::is_ascii_alphanumeric) {
                    self.at += 1;
                }
                let name = std::str::from_utf8(&self.s[start..self.at]).expect("letters");
                match NAMES.iter().position(|n| *n == name) {
                    Some(v) => Ok(Expr::Var(v)),
                    None => Err(format!(
                        "`{name}` is not a name an expression knows: use n, x, y, z, id or seed"
                    )),
                }
            }
            _ => Err(self.expected("a number, a name (n, x, y, z, id, seed) or `(`")),
        }
    }
}

impl Expr {
    fn eval(&self, vars: &Vars) -> Result<i64, &'static str> {
        Ok(match self {
            Expr::Num(v) => *v,
            Expr::Var(i) => vars[*i],
            Expr::Neg(e) => e.eval(vars)?.checked_neg().ok_or("overflow")?,
            Expr::Bin(op, a, b) => {
                let (a, b) = (a.eval(vars)?, b.eval(vars)?);
                match op {
                    b'+' => a.checked_add(b),
                    b'-' => a.checked_sub(b),
                    b'*' => a.checked_mul(b),
                    _ if b == 0 => return Err("division by zero"),
                    b'/' => a.checked_div(b),
                    _ => a.checked_rem(b),
                }
                .ok_or("overflow")?
            }
        })
    }
}

impl Setting {
    /// Sets the counter of every agent of `lat` (a run of seed `seed`). An error names the
    /// setting and the first agent whose value is not a counter's (-32767..32767), or a
    /// counter the lattice's dimension does not have.
    pub fn apply(&self, lat: &mut Lattice, seed: u64) -> Result<(), String> {
        if self.counter as usize >= lat.nc() {
            return Err(format!(
                "--set {}: {} has counters C00 to C{:02}",
                self.text,
                if lat.nc() == 25 { "2D" } else { "3D" },
                lat.nc() - 1
            ));
        }
        lat.ensure_counter(self.counter);
        let n = lat.len() as i64;
        for a in 0..lat.len() {
            let p = lat.pos[a];
            let vars = [
                n,
                p[0] as i64,
                p[1] as i64,
                p[2] as i64,
                a as i64,
                seed as i64,
            ];
            let v = self
                .expr
                .eval(&vars)
                .map_err(|e| format!("--set {}: agent {a}: {e}", self.text))?;
            let w = lat.width();
            if !w.holds(v) {
                return Err(format!(
                    "--set {}: agent {a} gets {v}, outside a counter's {}{}",
                    self.text,
                    w.range_text(),
                    if w == latticesim_vm::model::Width::W16
                        && latticesim_vm::model::Width::W32.holds(v)
                    {
                        " (32-bit counters hold it: `// latticesim: counters 32` in the rules file, or `--counters 32`)"
                    } else {
                        ""
                    }
                ));
            }
            lat.set_counter(a as u32, self.counter, v as i32);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eval(s: &str, vars: Vars) -> Result<i64, String> {
        let set: Setting = format!("C00={s}").parse()?;
        set.expr.eval(&vars).map_err(String::from)
    }

    /// Precedence, associativity, truncation toward zero, names, and the errors.
    #[test]
    fn expressions_evaluate_as_integers() {
        let v = [10, 3, -4, 0, 7, 2];
        assert_eq!(eval("id+1", v), Ok(8));
        assert_eq!(eval("1 + 2 * 3", v), Ok(7));
        assert_eq!(eval("(1 + 2) * 3", v), Ok(9));
        assert_eq!(eval("10 - 4 - 3", v), Ok(3));
        assert_eq!(eval("n / 4", v), Ok(2));
        assert_eq!(eval("y / 3", v), Ok(-1), "truncated toward zero");
        assert_eq!(eval("y % 3", v), Ok(-1), "the dividend's sign");
        assert_eq!(eval("(x + y) % 2", v), Ok(-1));
        assert_eq!(eval("-x * -2", v), Ok(6));
        assert_eq!(eval("seed*100+id", v), Ok(207));
        assert!(eval("id / (x - 3)", v)
            .unwrap_err()
            .contains("division by zero"));
        let e = eval("id +", v).unwrap_err();
        assert!(
            e.contains("expected a number, a name") && e.contains("character 5"),
            "{e}"
        );
        assert!(eval("idx", v).unwrap_err().contains("`idx` is not a name"));
        assert!(eval("(id", v).unwrap_err().contains("expected `)`"));
        assert!(eval("id id", v)
            .unwrap_err()
            .contains("expected an operator"));
        assert!("C0=1"
            .parse::<Setting>()
            .unwrap_err()
            .contains("not a counter"));
        assert!("C00"
            .parse::<Setting>()
            .unwrap_err()
            .contains("write a counter, `=`"));
    }
}
