//! A small seeded random number generator (xoshiro256++, seeded by SplitMix64).
//!
//! Kept in-tree so that a seed gives the same simulated elevator and the same fit on every
//! build, whatever version of a random-number crate the dependency graph resolves to.
//!
//! Beside it, the one moving-block bootstrap ([`moving_blocks`]) of the calibrations: a record
//! of healthy observations is resampled as blocks of consecutive observations, each starting
//! at a random index, which keeps the correlation within a block (load, winding temperature)
//! that resampling single observations would destroy.
//!
//! ```text
//! repeat until `total` indices are out:
//!     i0 = a uniform draw from the allowed starts            (see BlockStart)
//!     out i0, i0 + 1, …  while not block_ends(i0, i), i < len, and fewer than `total` are out
//! ```

/// xoshiro256++ with uniform and Gaussian draws.
#[derive(Clone, Debug)]
pub struct Rng {
    s: [u64; 4],
    spare: Option<f64>,
}

impl Rng {
    /// A generator whose whole stream is fixed by `seed`.
    pub fn new(seed: u64) -> Self {
        let mut x = seed;
        let mut next = || {
            x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = x;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        };
        Rng {
            s: [next(), next(), next(), next()],
            spare: None,
        }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let result = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    /// Uniform in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }

    /// Uniform integer in [0, n); 0 when n is 0.
    pub fn below(&mut self, n: u64) -> u64 {
        if n == 0 {
            return 0;
        }
        ((u128::from(self.next_u64()) * u128::from(n)) >> 64) as u64
    }

    /// True with probability p.
    pub fn chance(&mut self, p: f64) -> bool {
        self.next_f64() < p
    }

    /// Standard normal draw (Marsaglia polar method).
    pub fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        loop {
            let u = 2.0 * self.next_f64() - 1.0;
            let v = 2.0 * self.next_f64() - 1.0;
            let s = u * u + v * v;
            if s > 0.0 && s < 1.0 {
                let m = (-2.0 * s.ln() / s).sqrt();
                self.spare = Some(v * m);
                return u * m;
            }
        }
    }

    /// Exponential draw with the given mean.
    pub fn exponential(&mut self, mean: f64) -> f64 {
        -mean * (1.0 - self.next_f64()).ln()
    }

    /// An independent generator derived from this one (for sub-streams).
    pub fn fork(&mut self) -> Rng {
        Rng::new(self.next_u64())
    }
}

/// Where a moving block may start, and how the start is drawn. Both draws are uniform over
/// the starts; they use the random bits differently, and each caller keeps the one its seeds
/// were set with, so its results reproduce bit for bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlockStart {
    /// Any index of the record, drawn as `next_u64() mod len` (the risk calibration, whose
    /// blocks are a duration and are cut short at the end of the record).
    Anywhere,
    /// One of the first `len − block + 1` indices, so that a block of `block` indices fits
    /// whole, drawn with [`Rng::below`] (the chart calibration, whose blocks are a count).
    Whole {
        /// Indices of a whole block.
        block: usize,
    },
}

/// A moving-block bootstrap of a record of `len` observations: hands `emit` the indices of
/// `total` resampled observations in order. Each block starts at an index drawn as `start`
/// says and runs until `block_ends(first, i)` is true for its next index `i`, the record
/// ends, or `total` are out; a block always holds its first index. An empty record gives
/// nothing and draws nothing.
pub fn moving_blocks(
    rng: &mut Rng,
    len: usize,
    start: BlockStart,
    total: usize,
    mut block_ends: impl FnMut(usize, usize) -> bool,
    mut emit: impl FnMut(usize),
) {
    if len == 0 {
        return;
    }
    let mut done = 0;
    while done < total {
        let first = match start {
            BlockStart::Anywhere => (rng.next_u64() % len as u64) as usize,
            BlockStart::Whole { block } => {
                let starts = len - block.clamp(1, len) + 1;
                rng.below(starts as u64) as usize
            }
        };
        for i in first..len {
            if done >= total || (i > first && block_ends(first, i)) {
                break;
            }
            emit(i);
            done += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_stream_and_sane_moments() {
        let (mut a, mut b) = (Rng::new(42), Rng::new(42));
        assert_eq!(a.next_u64(), b.next_u64());
        let n = 200_000;
        let (mut m, mut m2) = (0.0, 0.0);
        for _ in 0..n {
            let z = a.normal();
            m += z;
            m2 += z * z;
        }
        let mean = m / f64::from(n);
        assert!(mean.abs() < 0.01, "{mean}");
        assert!((m2 / f64::from(n) - 1.0).abs() < 0.02);
        let u: f64 = (0..n).map(|_| a.next_f64()).sum::<f64>() / f64::from(n);
        assert!((u - 0.5).abs() < 0.005);
    }

    #[test]
    fn whole_blocks_fit_and_stop_at_the_total() {
        let mut rng = Rng::new(1);
        let mut out = Vec::new();
        let whole = BlockStart::Whole { block: 4 };
        moving_blocks(&mut rng, 10, whole, 10, |f, i| i - f >= 4, |i| out.push(i));
        assert_eq!(out.len(), 10);
        // Blocks of 4 consecutive indices, the last cut at the total, all within the record.
        for b in out.chunks(4) {
            assert!(b.windows(2).all(|w| w[1] == w[0] + 1), "{out:?}");
        }
        assert!(out.iter().all(|&i| i < 10));
        moving_blocks(
            &mut rng,
            0,
            whole,
            10,
            |_, _| false,
            |_| panic!("empty record"),
        );
    }

    #[test]
    fn blocks_from_anywhere_are_cut_at_the_end_of_the_record() {
        let mut rng = Rng::new(2);
        let mut out = Vec::new();
        moving_blocks(
            &mut rng,
            5,
            BlockStart::Anywhere,
            200,
            |_, _| false,
            |i| out.push(i),
        );
        assert_eq!(out.len(), 200);
        // A block runs to the end of the record, so each new block starts after a 4.
        for w in out.windows(2) {
            assert!(w[1] == w[0] + 1 || w[0] == 4, "{out:?}");
        }
    }
}
