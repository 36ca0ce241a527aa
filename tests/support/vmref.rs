//! An independent evaluator of Fidget `.vm` text, line by line in f64 with
//! Fidget's point semantics (`fidget-core/src/context/op.rs` and
//! `types/float.rs`), written without isoc's front end or IR: the oracle for
//! the `.vm` reader.

use std::collections::HashMap;

/// Evaluates the model `text` at `(x, y, z)`; the last instruction is the
/// result.
pub fn eval(text: &str, x: f64, y: f64, z: f64) -> f64 {
    let mut vals: HashMap<&str, f64> = HashMap::new();
    let mut last = f64::NAN;
    for line in text.lines() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let w: Vec<&str> = line.split_whitespace().collect();
        let arg = |i: usize| vals[w[i]];
        let v = match w[1] {
            "var-x" => x,
            "var-y" => y,
            "var-z" => z,
            "const" => w[2].parse().unwrap(),
            "neg" => -arg(2),
            "abs" => arg(2).abs(),
            "sqrt" => arg(2).sqrt(),
            "square" => arg(2) * arg(2),
            "floor" => arg(2).floor(),
            "ceil" => arg(2).ceil(),
            "round" => arg(2).round(),
            "sin" => arg(2).sin(),
            "cos" => arg(2).cos(),
            "tan" => arg(2).tan(),
            "asin" => arg(2).asin(),
            "acos" => arg(2).acos(),
            "atan" => arg(2).atan(),
            "exp" => arg(2).exp(),
            "ln" => arg(2).ln(),
            "not" => (arg(2) == 0.0) as u8 as f64,
            "add" => arg(2) + arg(3),
            "sub" => arg(2) - arg(3),
            "mul" => arg(2) * arg(3),
            "div" => arg(2) / arg(3),
            "atan2" => arg(2).atan2(arg(3)),
            "min" | "max" => {
                let (a, b) = (arg(2), arg(3));
                if a.is_nan() || b.is_nan() {
                    f64::NAN
                } else if w[1] == "min" {
                    a.min(b)
                } else {
                    a.max(b)
                }
            }
            "compare" => arg(2)
                .partial_cmp(&arg(3))
                .map_or(f64::NAN, |c| c as i8 as f64),
            "mod" => arg(2).rem_euclid(arg(3)),
            "and" => {
                if arg(2) == 0.0 {
                    arg(2)
                } else {
                    arg(3)
                }
            }
            "or" => {
                if arg(2) != 0.0 {
                    arg(2)
                } else {
                    arg(3)
                }
            }
            op => panic!("the reference does not know `{op}`"),
        };
        vals.insert(w[0], v);
        last = v;
    }
    last
}

/// `|a − b| ≤ 1e-9·max(1, |a|, |b|)`, NaN equal to NaN.
pub fn agree(a: f64, b: f64) -> bool {
    (a.is_nan() && b.is_nan()) || (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0)
}

/// The shared models directory (`../shared/models` beside the crate).
pub fn models_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/models")
}

/// The five shared models.
pub const MODELS: [&str; 5] = [
    "colonnade.vm",
    "prospero.vm",
    "tanglecube.vm",
    "hi.vm",
    "quarter.vm",
];

/// A tiny deterministic generator (xorshift64*).
pub struct Lcg(pub u64);

impl Lcg {
    pub fn unit(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let r = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d);
        (r >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in `[lo, hi]`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
}
