//! Fixed-point decimal text of coordinates, byte for byte what
//! `format!("{:.9}", x)` writes, without the general formatter.
//!
//! PERF: the standard formatter converts each number exactly (Grisu with
//! a bignum fallback), which made writing a 30² frame's OBJ a tenth of a
//! drape's instructions on the writer thread, beside the two solver
//! threads on a two-core host. Here `|x| 10⁹` is rounded in
//! double precision and printed as an integer. That product's rounding
//! error is at most half an ulp of it, so its nearest integer is the exact
//! one unless the product lies within an ulp of a half; those numbers, and
//! any too large for the integer path or not finite, go to the standard
//! formatter (round half to even on the exact binary value).

use std::fmt::Write as _;

/// Decimals of every coordinate: metres to the nanometre. Features of a
/// tight fold can touch within a tenth of a micrometre (the response keeps
/// them from crossing, not from touching), and at seven decimals a fold
/// read back from the frames could cross itself where the simulated cloth
/// does not (rotating-sphere: two cloth edges through the cloth at the
/// last frame, 40–70 nm inside, docs/benchmarks.md 1m).
pub const DECIMALS: usize = 9;

/// `10^DECIMALS`.
const SCALE: u64 = 10u64.pow(DECIMALS as u32);

/// Largest magnitude on the integer path (a kilometre scaled stays far
/// below 2⁵², where every fraction of the product is exact).
const FAST_BELOW: f64 = 1.0e6;

/// Appends `x` as `format!("{:.9}", x)` would write it.
pub fn push_fixed9(out: &mut Vec<u8>, x: f64) {
    let mag = x.abs();
    if mag < FAST_BELOW {
        let y = mag * SCALE as f64;
        let floor = y.floor();
        let frac = y - floor;
        // The ulp of `y` bounds its distance from the exact product twice
        // over; `y < 2⁵⁰`, so `frac` is exact.
        let ulp = f64::from_bits(y.to_bits() + 1) - y;
        if (frac - 0.5).abs() > ulp {
            let k = floor as u64 + u64::from(frac > 0.5);
            if x.is_sign_negative() {
                out.push(b'-');
            }
            push_u64(out, k / SCALE);
            out.push(b'.');
            let mut digits = [b'0'; DECIMALS];
            let mut f = k % SCALE;
            for d in digits.iter_mut().rev() {
                *d = b'0' + (f % 10) as u8;
                f /= 10;
            }
            out.extend_from_slice(&digits);
            return;
        }
    }
    let mut s = String::new();
    // Writing to a `String` cannot fail.
    let _ = write!(s, "{x:.DECIMALS$}");
    out.extend_from_slice(s.as_bytes());
}

/// Appends `n` in decimal.
pub fn push_u64(out: &mut Vec<u8>, mut n: u64) {
    let mut digits = [0u8; 20];
    let mut at = digits.len();
    loop {
        at -= 1;
        digits[at] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    out.extend_from_slice(&digits[at..]);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixed9(x: f64) -> String {
        let mut out = Vec::new();
        push_fixed9(&mut out, x);
        String::from_utf8(out).expect("ascii")
    }

    /// A small deterministic generator (xorshift), so the test needs no
    /// crate and sees the same numbers every run.
    fn numbers(seed: u64, count: usize) -> impl Iterator<Item = u64> {
        let mut s = seed;
        (0..count).map(move |_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        })
    }

    /// The same text as the standard formatter: at coordinates of every
    /// scale a scene has, at exact and near ties of the ninth decimal
    /// (where the integer path must step aside), and at the edges.
    #[test]
    fn writes_what_the_standard_formatter_writes() {
        let mut cases = vec![
            0.0,
            -0.0,
            1.0,
            -2.0,
            0.5e-9,
            1.5e-9,
            2.5e-9,
            -0.5e-9,
            1e-12,
            -1e-12,
            0.999_999_999_5,
            999_999.999_999_999_5,
            1.0e6,
            -3.7e8,
            1e300,
            f64::MIN_POSITIVE,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for r in numbers(0x9e37_79b9_7f4a_7c15, 200_000) {
            // Uniform in a few metres, then at every exponent, then
            // exact multiples of half a nanometre and their neighbours.
            let unit = (r >> 11) as f64 / (1u64 << 53) as f64;
            let sign = if r & 1 == 0 { 1.0 } else { -1.0 };
            cases.push(sign * 4.0 * unit);
            cases.push(sign * unit * 10f64.powi((r % 24) as i32 - 14));
            let tie = sign * ((r >> 20) % 4_000_000_000) as f64 * 0.5e-9;
            cases.push(tie);
            cases.push(f64::from_bits(tie.to_bits() + 1));
            cases.push(f64::from_bits(tie.to_bits().saturating_sub(1)));
        }
        for x in cases {
            assert_eq!(fixed9(x), format!("{x:.9}"), "{x:e}");
        }
    }

    #[test]
    fn integers_in_decimal() {
        for n in [0, 7, 10, 4_294_967_295, u64::MAX] {
            let mut out = Vec::new();
            push_u64(&mut out, n);
            assert_eq!(out, n.to_string().into_bytes());
        }
    }
}
