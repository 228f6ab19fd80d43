//! The colours of states, shared by `render` and the viewer (`serve`): a categorical
//! palette handed out in order of first appearance in the run (agents in id order at step
//! 0, then each step's new states in id order), so that a run's states keep their colours
//! from its first step to its last and differ as much as the palette allows.
//!
//! The first eight colours are the seven of Okabe and Ito's colour-blind safe set and
//! Paul Tol's indigo; the next are chosen one at a time from a grid of sRGB colours as the
//! one farthest (in the OKLab perceptual space) from all chosen so far, the white
//! background and the grey of walls, up to [`GENERATED`] colours; beyond that they repeat.
//! A user palette (`--palette FILE`) replaces the sequence, or pins states to colours.

use std::collections::HashMap;
use std::sync::OnceLock;

/// [`Palette::index`] with a small table in front: a run has few states, so nearly every
/// lookup is answered without hashing by the map (a mix of the state's bytes and a
/// comparison or two).
struct Lookup<'p> {
    palette: &'p Palette,
    /// States (their five bytes, with the top bit set, so that 0 is an empty slot) and
    /// their indices, in open addressing; filled up to half, then the map answers.
    table: [(u64, Option<u32>); 256],
    filled: usize,
}

impl<'p> Lookup<'p> {
    fn new(palette: &'p Palette) -> Lookup<'p> {
        Lookup {
            palette,
            table: [(0, None); 256],
            filled: 0,
        }
    }

    fn get(&mut self, s: &[u8; 5]) -> Option<u32> {
        let key = u64::from_le_bytes([s[0], s[1], s[2], s[3], s[4], 0, 0, 0x80]);
        // splitmix64's finaliser: states that differ in one letter land far apart.
        let mut h = key;
        h = (h ^ (h >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h = (h ^ (h >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        let mut slot = (h ^ (h >> 31)) as usize & 255;
        loop {
            match self.table[slot] {
                (k, index) if k == key => return index,
                (0, _) if self.filled < 128 => {
                    let index = self.palette.index(s);
                    self.table[slot] = (key, index);
                    self.filled += 1;
                    return index;
                }
                (0, _) => return self.palette.index(s),
                _ => slot = (slot + 1) & 255,
            }
        }
    }
}

/// Colour-blind safe: Okabe and Ito's orange, sky blue, bluish green, yellow, blue,
/// vermillion, reddish purple, and Paul Tol's indigo.
const FIRST: [[u8; 3]; 8] = [
    [0xE6, 0x9F, 0x00],
    [0x56, 0xB4, 0xE9],
    [0x00, 0x9E, 0x73],
    [0xF0, 0xE4, 0x42],
    [0x00, 0x72, 0xB2],
    [0xD5, 0x5E, 0x00],
    [0xCC, 0x79, 0xA7],
    [0x33, 0x22, 0x88],
];

/// Colours in the default sequence.
pub const GENERATED: usize = 40;

/// sRGB (0..=255) as OKLab (L, a, b), after Björn Ottosson's definition.
pub fn oklab(c: [u8; 3]) -> [f64; 3] {
    let lin = |v: u8| {
        let v = v as f64 / 255.0;
        if v <= 0.04045 {
            v / 12.92
        } else {
            ((v + 0.055) / 1.055).powf(2.4)
        }
    };
    let [r, g, b] = c.map(lin);
    let l = (0.412_221_470_8 * r + 0.536_332_536_3 * g + 0.051_445_992_9 * b).cbrt();
    let m = (0.211_903_498_2 * r + 0.680_699_545_1 * g + 0.107_396_956_6 * b).cbrt();
    let s = (0.088_302_461_9 * r + 0.281_718_837_6 * g + 0.629_978_700_5 * b).cbrt();
    [
        0.210_454_255_3 * l + 0.793_617_785_0 * m - 0.004_072_046_8 * s,
        1.977_998_495_1 * l - 2.428_592_205_0 * m + 0.450_593_709_9 * s,
        0.025_904_037_1 * l + 0.782_771_766_2 * m - 0.808_675_766_0 * s,
    ]
}

/// The distance of two colours in OKLab.
pub fn distance(a: [u8; 3], b: [u8; 3]) -> f64 {
    let (a, b) = (oklab(a), oklab(b));
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The default sequence: [`FIRST`], then greedy farthest-point choices.
pub fn default_colours() -> &'static [[u8; 3]] {
    static COLOURS: OnceLock<Vec<[u8; 3]>> = OnceLock::new();
    COLOURS.get_or_init(|| {
        let grid: Vec<([u8; 3], [f64; 3])> = (0..16u32 * 16 * 16)
            .map(|i| {
                [
                    (i >> 8) as u8 * 17,
                    ((i >> 4) & 15) as u8 * 17,
                    (i & 15) as u8 * 17,
                ]
            })
            .map(|c| (c, oklab(c)))
            // Neither too light to see on white nor too dark to tell from bonds.
            .filter(|(_, l)| (0.45..=0.88).contains(&l[0]))
            .collect();
        let mut chosen: Vec<[u8; 3]> = FIRST.to_vec();
        let avoid = [[255, 255, 255], [150, 150, 150]];
        let mut nearest: Vec<f64> = (grid.iter())
            .map(|(c, _)| {
                (chosen.iter().chain(&avoid))
                    .map(|&k| distance(*c, k))
                    .fold(f64::MAX, f64::min)
            })
            .collect();
        while chosen.len() < GENERATED {
            let (best, _) =
                (nearest.iter().enumerate())
                    .fold((0, -1.0), |b, (i, &d)| if d > b.1 { (i, d) } else { b });
            let c = grid[best].0;
            chosen.push(c);
            for (n, (g, _)) in nearest.iter_mut().zip(&grid) {
                *n = n.min(distance(*g, c));
            }
        }
        chosen
    })
}

/// A `#rrggbb` colour.
pub fn hex(c: [u8; 3]) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// A colour written `#rrggbb` (or `#rgb`).
fn parse_hex(s: &str) -> Option<[u8; 3]> {
    let h = s.strip_prefix('#')?;
    let v = u32::from_str_radix(h, 16).ok()?;
    match h.len() {
        6 => Some([(v >> 16) as u8, (v >> 8) as u8, v as u8]),
        3 => Some([(v >> 8) & 15, (v >> 4) & 15, v & 15].map(|x| x as u8 * 17)),
        _ => None,
    }
}

/// The colours of a run's states.
#[derive(Clone, Debug)]
pub struct Palette {
    /// The colours handed out, in order.
    sequence: Vec<[u8; 3]>,
    /// States given a colour by the user.
    pinned: HashMap<[u8; 5], [u8; 3]>,
    /// Each state seen: its colour and its place in `order`.
    seen: HashMap<[u8; 5], ([u8; 3], u32)>,
    /// The states seen that took a colour of the sequence.
    handed: usize,
    /// The states seen, in order of first appearance.
    order: Vec<[u8; 5]>,
}

impl Default for Palette {
    fn default() -> Palette {
        Palette {
            sequence: default_colours().to_vec(),
            pinned: HashMap::new(),
            seen: HashMap::new(),
            handed: 0,
            order: Vec::new(),
        }
    }
}

impl Palette {
    /// A user palette file: a line `#rrggbb` adds a colour to the sequence (which then
    /// replaces the default one), a line `STATE #rrggbb` gives a state its colour; blank
    /// lines and text after `//` are ignored. Errors name the line and column.
    pub fn parse(text: &str, name: &str) -> Result<Palette, String> {
        let mut p = Palette {
            sequence: Vec::new(),
            ..Palette::default()
        };
        for (i, line) in text.lines().enumerate() {
            let body = line.split("//").next().unwrap_or("");
            let words: Vec<&str> = body.split_whitespace().collect();
            let col = |w: &str| body.find(w).map_or(1, |k| k + 1);
            let at = |w: &str| format!("{name}:{}:{}", i + 1, col(w));
            let colour = |w: &str| {
                parse_hex(w)
                    .ok_or_else(|| format!("{}: `{w}` is not a colour; write #rrggbb", at(w)))
            };
            match words[..] {
                [] => {}
                [c] => p.sequence.push(colour(c)?),
                [state, c] => {
                    let bytes = state.as_bytes();
                    let Ok(s) = <[u8; 5]>::try_from(bytes) else {
                        return Err(format!(
                            "{}: `{state}` is not a state; a state has 5 characters",
                            at(state)
                        ));
                    };
                    p.pinned.insert(s, colour(c)?);
                }
                _ => {
                    return Err(format!(
                        "{}: write `#rrggbb` or `STATE #rrggbb` on a line",
                        at(words[2])
                    ))
                }
            }
        }
        if p.sequence.is_empty() {
            p.sequence = default_colours().to_vec();
        }
        Ok(p)
    }

    /// Reads a user palette file.
    pub fn read(path: &std::path::Path) -> Result<Palette, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read `{}`: {e}", path.display()))?;
        Palette::parse(&text, &path.display().to_string())
    }

    /// Gives each state of `states` not seen before its colour, in order, and counts the
    /// agents in each state, by index ([`Palette::index`]).
    pub fn observe_counting(&mut self, states: &[[u8; 5]]) -> Vec<u64> {
        let mut counts = vec![0u64; self.order().len()];
        // States not seen before, in order of appearance, with how many agents each (a
        // million agents are looked at every step the viewer takes: through the table,
        // not the map).
        let mut new: Vec<([u8; 5], u64)> = Vec::new();
        let mut at: HashMap<[u8; 5], usize> = HashMap::new();
        let mut lookup = Lookup::new(self);
        for s in states {
            match lookup.get(s) {
                Some(i) => counts[i as usize] += 1,
                None => {
                    let k = *at.entry(*s).or_insert_with(|| {
                        new.push((*s, 0));
                        new.len() - 1
                    });
                    new[k].1 += 1;
                }
            }
        }
        for (s, n) in new {
            self.colour(&s);
            let i = self.index(&s).expect("just coloured") as usize;
            counts.resize(counts.len().max(i + 1), 0);
            counts[i] += n;
        }
        counts
    }

    /// Gives each state of `states` not seen before its colour, in order.
    pub fn observe(&mut self, states: &[[u8; 5]]) {
        self.observe_counting(states);
    }

    /// The indices of `states` (see [`Palette::index`]; 0 for a state never seen).
    pub fn indices(&self, states: &[[u8; 5]]) -> Vec<u32> {
        let mut lookup = Lookup::new(self);
        states.iter().map(|s| lookup.get(s).unwrap_or(0)).collect()
    }

    /// The colour of a state, given it now if it has none yet.
    pub fn colour(&mut self, s: &[u8; 5]) -> [u8; 3] {
        if let Some(&(c, _)) = self.seen.get(s) {
            return c;
        }
        let c = match self.pinned.get(s) {
            Some(&c) => c,
            None => {
                self.handed += 1;
                self.sequence[(self.handed - 1) % self.sequence.len()]
            }
        };
        self.seen.insert(*s, (c, self.order.len() as u32));
        self.order.push(*s);
        c
    }

    /// The place of a state in the order of first appearance, if it was seen: an index
    /// that stays the state's for the run (binary frames use it).
    pub fn index(&self, s: &[u8; 5]) -> Option<u32> {
        self.seen.get(s).map(|&(_, i)| i)
    }

    /// The colour a state was given (black for a state never seen).
    pub fn get(&self, s: &[u8; 5]) -> [u8; 3] {
        self.seen.get(s).map_or([0, 0, 0], |&(c, _)| c)
    }

    /// The states seen, in order of first appearance.
    pub fn order(&self) -> &[[u8; 5]] {
        &self.order
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn min_distance(c: &[[u8; 3]]) -> f64 {
        let mut m = f64::MAX;
        for i in 0..c.len() {
            for j in 0..i {
                m = m.min(distance(c[i], c[j]));
            }
        }
        m
    }

    #[test]
    fn the_colours_are_far_apart_in_oklab() {
        let c = default_colours();
        assert_eq!(c.len(), GENERATED);
        assert!(min_distance(&c[..8]) > 0.15, "{}", min_distance(&c[..8]));
        assert!(min_distance(&c[..16]) > 0.1, "{}", min_distance(&c[..16]));
        assert!(min_distance(c) > 0.07, "{}", min_distance(c));
        // The near twins (TREEA #425fd7, TREEE #4256d7) were 0.02 apart.
        assert!(distance([0x42, 0x5f, 0xd7], [0x42, 0x56, 0xd7]) < 0.03);
        // OKLab of white is L = 1.
        assert!((oklab([255, 255, 255])[0] - 1.0).abs() < 1e-6);
    }

    #[test]
    fn indices_through_the_table_agree_with_the_map() {
        // Few states (the table answers) and many (past its half: the map answers), with
        // states one letter apart, which a weak mix would put in one slot.
        for count in [7usize, 300] {
            let states: Vec<[u8; 5]> = (0..count * 10)
                .map(|i| {
                    let k = (i * 7919) % count;
                    *format!("G{:04}", k).as_bytes().first_chunk::<5>().unwrap()
                })
                .collect();
            let mut p = Palette::default();
            p.observe(&states[..count * 5]);
            p.observe(&states);
            assert_eq!(p.order().len(), count);
            let got = p.indices(&states);
            for (s, i) in states.iter().zip(&got) {
                assert_eq!(Some(*i), p.index(s));
            }
            // First appearance decides the order.
            let mut first: Vec<[u8; 5]> = Vec::new();
            for s in &states {
                if !first.contains(s) {
                    first.push(*s);
                }
            }
            assert_eq!(p.order(), &first[..]);
        }
        assert_eq!(Palette::default().indices(&[*b"NEVER"]), [0]);
    }

    #[test]
    fn colours_go_in_order_of_first_appearance_and_stay() {
        let mut p = Palette::default();
        p.observe(&[*b"TREEA", *b"TREEA", *b"TROOT", *b"TREEA"]);
        p.observe(&[*b"TREEE", *b"TROOT"]);
        let c = default_colours();
        assert_eq!(p.colour(b"TREEA"), c[0]);
        assert_eq!(p.colour(b"TROOT"), c[1]);
        assert_eq!(p.colour(b"TREEE"), c[2]);
    }

    #[test]
    fn a_user_palette_pins_states_and_replaces_the_sequence() {
        let text = "// mine\n#ff0000\nLEAD0 #00ff00 // the leader\n\n#00f\n";
        let mut p = Palette::parse(text, "p.txt").unwrap();
        assert_eq!(p.colour(b"INIT0"), [255, 0, 0]);
        assert_eq!(p.colour(b"LEAD0"), [0, 255, 0]);
        assert_eq!(p.colour(b"FOLLW"), [0, 0, 255]);
        assert_eq!(p.colour(b"OTHER"), [255, 0, 0], "the sequence repeats");
        let e = Palette::parse("#ff0000\nLEAD #00ff00\n", "p.txt").unwrap_err();
        assert_eq!(
            e,
            "p.txt:2:1: `LEAD` is not a state; a state has 5 characters"
        );
        let e = Palette::parse("  red\n", "p.txt").unwrap_err();
        assert_eq!(e, "p.txt:1:3: `red` is not a colour; write #rrggbb");
        let e = Palette::parse("A #fff #000\n", "p.txt").unwrap_err();
        assert!(e.starts_with("p.txt:1:8:"), "{e}");
    }
}
