//! The correcting network of the hybrid model (paper, Sec. 3.2): a 3-16-16-2 tanh MLP.
//!
//! ```text
//! x  = (v / v_rated, λ, a / 1 m/s²)
//! h1 = tanh(W1·x + b1)        16
//! h2 = tanh(W2·h1 + b2)       16
//! y  = W3·h2 + b3             2
//! δU = y0 · scale_u,  δF = y1 · scale_f
//! ```
//!
//! Written by hand: 370 weights are far below the size where a tensor library pays for its
//! per-operation overhead and its compile time; forward and backward are checked against
//! central differences in the tests below.

use serde::{Deserialize, Serialize};

use crate::rng::Rng;

/// Inputs of the network.
pub const N_IN: usize = 3;
/// Units in each hidden layer.
pub const N_HID: usize = 16;
/// Outputs of the network.
pub const N_OUT: usize = 2;
/// Number of weights and biases.
pub const N_WEIGHTS: usize = N_HID * N_IN + N_HID + N_HID * N_HID + N_HID + N_OUT * N_HID + N_OUT;

// Offsets of the blocks in the flat weight vector.
const W1: usize = 0;
const B1: usize = W1 + N_HID * N_IN;
const W2: usize = B1 + N_HID;
const B2: usize = W2 + N_HID * N_HID;
const W3: usize = B2 + N_HID;
const B3: usize = W3 + N_OUT * N_HID;

/// The residual network δ(x) = (δU, δF) with its fixed input and output scaling.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResidualNet {
    /// Flat weights: W1 (16×3, row-major), b1, W2 (16×16), b2, W3 (2×16), b3.
    pub weights: Vec<f64>,
    /// Divisors of the inputs (v, λ, a) before the first layer.
    pub input_scale: [f64; N_IN],
    /// Multipliers of the outputs: δU in V and δF in N per unit of network output.
    pub output_scale: [f64; N_OUT],
    /// The inputs the fit saw; `None` in models fitted before it was kept, whose network is
    /// evaluated wherever it is asked.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub domain: Option<InputDomain>,
}

/// The box of raw inputs (v, λ, a) a network was fitted on, per direction of travel (down,
/// at rest, up): outside it the network is held at the box's edge instead of extrapolated.
///
/// A tanh network is a fit of the inputs it saw and nothing beyond: a training of the
/// paper's three morning hours sees loaded cars going up and empty ones coming down, and the
/// evening's loaded down trips lie outside it. There the correction is whatever the weights
/// extrapolate to, and a wrong correction is a residual the risk reads as a fault; at the
/// edge the correction is one the data checked, and past it the physics carries the
/// prediction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InputDomain {
    /// Per direction (down, at rest, up): [min, max] of v, λ and a; `None` for a direction
    /// the fit never saw (no hold there).
    pub boxes: [Option<[[f64; 2]; N_IN]>; 3],
}

impl InputDomain {
    /// The box of `inputs` (v, λ, a) per direction of v; `None` when there are none.
    pub fn of(inputs: impl Iterator<Item = [f64; N_IN]>) -> Option<InputDomain> {
        let mut boxes: [Option<[[f64; 2]; N_IN]>; 3] = [None; 3];
        for x in inputs {
            if !x.iter().all(|v| v.is_finite()) {
                continue;
            }
            let b =
                boxes[direction(x[0])].get_or_insert([[x[0], x[0]], [x[1], x[1]], [x[2], x[2]]]);
            for (r, v) in b.iter_mut().zip(x) {
                r[0] = r[0].min(v);
                r[1] = r[1].max(v);
            }
        }
        boxes
            .iter()
            .any(Option::is_some)
            .then_some(InputDomain { boxes })
    }

    /// Checks a hand-edited model: every edge finite, each range in order, and each box's
    /// speeds of its own direction (a box with min > max would make [`Self::hold`] panic).
    ///
    /// # Errors
    /// A message naming the first box out of order.
    pub fn validate(&self) -> std::result::Result<(), String> {
        const NAMES: [&str; 3] = ["down", "at rest", "up"];
        for (i, (b, name)) in self.boxes.iter().zip(NAMES).enumerate() {
            let Some(b) = b else { continue };
            if b.iter()
                .any(|r| !(r[0].is_finite() && r[1].is_finite() && r[0] <= r[1]))
            {
                return Err(format!(
                    "net.domain: the {name} box needs finite ranges with min <= max"
                ));
            }
            if direction(b[0][0]) != i || direction(b[0][1]) != i {
                return Err(format!(
                    "net.domain: the {name} box holds speeds of another direction"
                ));
            }
        }
        Ok(())
    }

    /// `x` held inside its direction's box.
    pub fn hold(&self, x: [f64; N_IN]) -> [f64; N_IN] {
        match &self.boxes[direction(x[0])] {
            Some(b) => std::array::from_fn(|i| x[i].clamp(b[i][0], b[i][1])),
            None => x,
        }
    }
}

/// Index of the direction of `v` in [`InputDomain::boxes`]: 0 down, 1 at rest, 2 up.
fn direction(v: f64) -> usize {
    if v < 0.0 {
        0
    } else if v > 0.0 {
        2
    } else {
        1
    }
}

/// Activations kept from a forward pass of `L` samples side by side (one per lane) for the
/// backward pass; the monitor keeps one, the fit [`LANES`].
#[derive(Clone, Copy, Debug)]
pub struct NetCache<const L: usize = 1> {
    x: [[f64; L]; N_IN],
    h1: [[f64; L]; N_HID],
    h2: [[f64; L]; N_HID],
}

impl<const L: usize> Default for NetCache<L> {
    fn default() -> Self {
        NetCache {
            x: [[0.0; L]; N_IN],
            h1: [[0.0; L]; N_HID],
            h2: [[0.0; L]; N_HID],
        }
    }
}

/// Samples the fit passes through the network side by side. Each lane's arithmetic is the
/// single sample's, in the same order, so a lane's output is bit-identical to a pass of that
/// sample alone; side by side, the lanes' independent sums fill the processor's pipelines (a
/// sample alone waits on each add of its 16-term dot products) and its vector registers.
/// Eight: two AVX2 registers of four (a week's `liftwatch fit` took 0.96x the CPU of four
/// lanes, 3 interleaved runs each, with the same model file).
pub const LANES: usize = 8;

impl ResidualNet {
    /// A network with Glorot-uniform hidden weights and a zero last layer, so that it starts
    /// as no correction at all and the physics alone explains the data at the first step.
    pub fn new(seed: u64, input_scale: [f64; N_IN], output_scale: [f64; N_OUT]) -> Self {
        let mut rng = Rng::new(seed);
        let mut weights = vec![0.0; N_WEIGHTS];
        let lim1 = (6.0 / (N_IN + N_HID) as f64).sqrt();
        let lim2 = (6.0 / (2 * N_HID) as f64).sqrt();
        for w in &mut weights[W1..B1] {
            *w = rng.uniform(-lim1, lim1);
        }
        for w in &mut weights[W2..B2] {
            *w = rng.uniform(-lim2, lim2);
        }
        ResidualNet {
            weights,
            input_scale,
            output_scale,
            domain: None,
        }
    }

    /// δ(x) = (δU in V, δF in N) for the raw inputs (v, λ, a), held inside the fit's
    /// [`InputDomain`], through [`forward_raw`].
    #[inline]
    pub fn forward(&self, v: f64, lambda: f64, a: f64) -> [f64; N_OUT] {
        let [v, lambda, a] = match &self.domain {
            Some(d) => d.hold([v, lambda, a]),
            None => [v, lambda, a],
        };
        let x = self.scaled(v, lambda, a);
        let y = crate::wide::wide(
            #[inline(always)]
            || forward_raw(&self.weights, x, &mut NetCache::default()),
        );
        [y[0] * self.output_scale[0], y[1] * self.output_scale[1]]
    }

    /// Inputs divided by their scales.
    pub fn scaled(&self, v: f64, lambda: f64, a: f64) -> [f64; N_IN] {
        [
            v / self.input_scale[0],
            lambda / self.input_scale[1],
            a / self.input_scale[2],
        ]
    }
}

/// tanh through one exponential: 1 − 2/(e^{2x} + 1), exact to ~1e-16 absolute. The C
/// library's `tanh` was half the cost of a training gradient; its `exp` is a call the
/// compiler cannot vectorise and differs between C libraries in the last bit, which a fit of
/// many iterations turns into different parameters. [`exp_bounded`] is plain arithmetic: it
/// runs on several units of a layer at once and gives the same bits on every platform.
#[inline(always)]
fn tanh(x: f64) -> f64 {
    1.0 - 2.0 / (exp_bounded(2.0 * x.clamp(-TANH_SATURATES, TANH_SATURATES)) + 1.0)
}

/// |x| beyond which tanh(x) rounds to ±1 in f64 (1 − tanh 19.1 < 2⁻⁵⁴); clamping there
/// keeps [`exp_bounded`]'s argument within ±40.
const TANH_SATURATES: f64 = 20.0;

/// 1.5·2⁵²: added to a float of magnitude below 2⁵¹, it rounds it to an integer held in the
/// low bits of the sum's mantissa.
const ROUNDING_SHIFT: f64 = 6_755_399_441_055_744.0;
/// ln 2 split in two (fdlibm's): the high part has 32 trailing zero bits, so k·LN2_HI is
/// exact for |k| < 2²⁰ and the reduced argument loses nothing.
const LN2_HI: f64 = 0.693_147_180_369_123_8;
/// The rest of ln 2.
const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
/// 1/n! for n = 0..=12: e^r by its Taylor series on |r| ≤ ln2/2, whose remainder
/// |r|¹³/13! is below 2.4e-16 of e^r.
const EXP_TAYLOR: [f64; 13] = [
    1.0,
    1.0,
    1.0 / 2.0,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
    1.0 / 5_040.0,
    1.0 / 40_320.0,
    1.0 / 362_880.0,
    1.0 / 3_628_800.0,
    1.0 / 39_916_800.0,
    1.0 / 479_001_600.0,
];

/// e^y for |y| ≤ 40 (NaN stays NaN), within 4e-16 relative (two units in the last place): y = k·ln 2 + r with k the
/// nearest integer to y/ln 2 and |r| ≤ ln2/2, e^r by [`EXP_TAYLOR`], 2^k built in the
/// exponent bits. Only adds, multiplies and integer bit operations: it vectorises and is the
/// same on every platform.
#[inline(always)]
fn exp_bounded(y: f64) -> f64 {
    let t = y * std::f64::consts::LOG2_E + ROUNDING_SHIFT;
    let k = t - ROUNDING_SHIFT;
    let r = (y - k * LN2_HI) - k * LN2_LO;
    let p = EXP_TAYLOR.iter().rev().fold(0.0, |acc, c| acc * r + c);
    // t's low mantissa bits hold k (two's complement): 2^k has exponent field k + 1023.
    let two_k = f64::from_bits(
        t.to_bits()
            .wrapping_sub(ROUNDING_SHIFT.to_bits())
            .wrapping_add(1023)
            << 52,
    );
    p * two_k
}

/// Forward pass on scaled inputs with explicit weights; returns the unscaled outputs y and
/// keeps the activations in `cache` for [`backward_raw`]: [`forward_lanes`] of one sample.
///
/// # Panics
/// When `w` does not hold [`N_WEIGHTS`] weights (a model file with another count is refused
/// when it is read).
#[inline(always)]
pub fn forward_raw(w: &[f64], x: [f64; N_IN], cache: &mut NetCache) -> [f64; N_OUT] {
    let y = forward_lanes(w, &[x], cache);
    [y[0][0], y[1][0]]
}

/// Forward pass of `L` samples side by side (scaled inputs, one per lane); returns the
/// unscaled outputs y per output and lane and keeps the activations in `cache` for
/// [`backward_lanes`].
///
/// The one forward pass of the crate: training, the fit's reports and the monitor all go
/// through it, so a model is monitored with exactly the arithmetic it was trained with.
/// Fixed-size blocks let the compiler drop the bounds checks of the inner loops.
///
/// # Panics
/// When `w` does not hold [`N_WEIGHTS`] weights.
#[inline(always)]
pub fn forward_lanes<const L: usize>(
    w: &[f64],
    x: &[[f64; N_IN]; L],
    cache: &mut NetCache<L>,
) -> [[f64; L]; N_OUT] {
    let w: &[f64; N_WEIGHTS] = w.try_into().expect("a network has N_WEIGHTS weights");
    for (i, xi) in cache.x.iter_mut().enumerate() {
        *xi = std::array::from_fn(|l| x[l][i]);
    }
    // Each layer's pre-activations first, then one loop of tanh over all its units and
    // lanes, which the compiler runs several at a time.
    for j in 0..N_HID {
        let r = &w[W1 + j * N_IN..W1 + (j + 1) * N_IN];
        let mut z = [w[B1 + j]; L];
        for (ri, xi) in r.iter().zip(&cache.x) {
            for (zl, xl) in z.iter_mut().zip(xi) {
                *zl += ri * xl;
            }
        }
        cache.h1[j] = z;
    }
    tanh_layer(&mut cache.h1);
    for j in 0..N_HID {
        let r: &[f64; N_HID] = w[W2 + j * N_HID..W2 + (j + 1) * N_HID]
            .try_into()
            .expect("a row of W2 has N_HID weights");
        let z = dot_lanes(r, &cache.h1);
        cache.h2[j] = z.map(|z| w[B2 + j] + z);
    }
    tanh_layer(&mut cache.h2);
    std::array::from_fn(|k| {
        let r: &[f64; N_HID] = w[W3 + k * N_HID..W3 + (k + 1) * N_HID]
            .try_into()
            .expect("a row of W3 has N_HID weights");
        let z = dot_lanes(r, &cache.h2);
        z.map(|z| w[B3 + k] + z)
    })
}

/// tanh of every unit and lane of a layer. Plain loops, not an iterator adapter: `flatten`'s
/// `fold` is a function of its own that the compiler may leave out of line, and out of line it
/// is compiled without the AVX2 of [`crate::wide`] (it was 29 % of a fit's CPU so).
#[inline(always)]
fn tanh_layer<const L: usize>(layer: &mut [[f64; L]; N_HID]) {
    for unit in layer.iter_mut() {
        for h in unit.iter_mut() {
            *h = tanh(*h);
        }
    }
}

/// Σ_i r_i·h_i per lane, summed in the order of i from −0 (as `Iterator::sum` does).
#[inline(always)]
fn dot_lanes<const L: usize>(r: &[f64; N_HID], h: &[[f64; L]; N_HID]) -> [f64; L] {
    let mut z = [-0.0; L];
    for (ri, hi) in r.iter().zip(h) {
        for (zl, hl) in z.iter_mut().zip(hi) {
            *zl += ri * hl;
        }
    }
    z
}

/// Backward pass: adds dL/dw to `grad` for the output sensitivity `dy` = dL/dy:
/// [`backward_lanes`] of one sample.
///
/// # Panics
/// When `w` or `grad` does not hold [`N_WEIGHTS`] weights.
pub fn backward_raw(w: &[f64], cache: &NetCache, dy: [f64; N_OUT], grad: &mut [f64]) {
    backward_lanes(w, cache, &dy.map(|d| [d]), 1, grad);
}

/// Backward pass of the first `active` lanes of a [`forward_lanes`] pass: adds dL/dw for the
/// output sensitivities `dy` (per output and lane) to `grad`, lane after lane for each
/// weight, so that the sum over samples runs in their order. (Running sums per lane, added
/// up at the end of a pass, vectorise the adds but were 1.3-1.5 times slower over a
/// fit: four times the gradient's memory in the inner loops.)
///
/// # Panics
/// When `w` or `grad` does not hold [`N_WEIGHTS`] weights.
#[inline(always)]
pub fn backward_lanes<const L: usize>(
    w: &[f64],
    cache: &NetCache<L>,
    dy: &[[f64; L]; N_OUT],
    active: usize,
    grad: &mut [f64],
) {
    let w: &[f64; N_WEIGHTS] = w.try_into().expect("a network has N_WEIGHTS weights");
    let grad: &mut [f64; N_WEIGHTS] = grad.try_into().expect("a gradient has N_WEIGHTS terms");
    let n = active.min(L);
    let mut dh2 = [[0.0; L]; N_HID];
    for (k, d) in dy.iter().enumerate() {
        add_lanes(&mut grad[B3 + k], d, None, n);
        for j in 0..N_HID {
            let wkj = w[W3 + k * N_HID + j];
            add_lanes(&mut grad[W3 + k * N_HID + j], d, Some(&cache.h2[j]), n);
            for (a, dl) in dh2[j].iter_mut().zip(d) {
                *a += dl * wkj;
            }
        }
    }
    let mut dh1 = [[0.0; L]; N_HID];
    for j in 0..N_HID {
        let dz: [f64; L] =
            std::array::from_fn(|l| dh2[j][l] * (1.0 - cache.h2[j][l] * cache.h2[j][l]));
        add_lanes(&mut grad[B2 + j], &dz, None, n);
        let row = W2 + j * N_HID;
        for i in 0..N_HID {
            add_lanes(&mut grad[row + i], &dz, Some(&cache.h1[i]), n);
            let wji = w[row + i];
            for (a, dl) in dh1[i].iter_mut().zip(&dz) {
                *a += dl * wji;
            }
        }
    }
    for j in 0..N_HID {
        let dz: [f64; L] =
            std::array::from_fn(|l| dh1[j][l] * (1.0 - cache.h1[j][l] * cache.h1[j][l]));
        add_lanes(&mut grad[B1 + j], &dz, None, n);
        for i in 0..N_IN {
            add_lanes(&mut grad[W1 + j * N_IN + i], &dz, Some(&cache.x[i]), n);
        }
    }
}

/// g += d_l·h_l (or d_l without `h`) for the first `n` lanes, one lane after the other: the
/// order a pass of the samples one by one adds them in.
#[inline(always)]
fn add_lanes<const L: usize>(g: &mut f64, d: &[f64; L], h: Option<&[f64; L]>, n: usize) {
    match h {
        Some(h) => d[..n].iter().zip(h).for_each(|(dl, hl)| *g += dl * hl),
        None => d[..n].iter().for_each(|dl| *g += dl),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn has_the_papers_370_weights() {
        assert_eq!(N_WEIGHTS, 370);
    }

    #[test]
    fn fast_tanh_matches_the_library() {
        let mut worst = 0.0f64;
        for i in -250_000..250_000 {
            let x = f64::from(i) * 1e-4 + 3.7e-6;
            worst = worst.max((tanh(x) - x.tanh()).abs());
        }
        assert!(worst < 4e-16, "tanh off by {worst:e}");
        assert_eq!(tanh(1e6), 1.0);
        assert_eq!(tanh(-1e6), -1.0);
        assert_eq!(tanh(19.5), 1.0);
        assert!(tanh(f64::NAN).is_nan());
    }

    #[test]
    fn bounded_exp_is_within_a_few_ulp_of_the_library() {
        let mut worst = 0.0f64;
        for i in -400_000..=400_000 {
            let y = f64::from(i) * 1e-4 + 1.3e-7;
            let (e, lib) = (exp_bounded(y), y.exp());
            worst = worst.max(((e - lib) / lib).abs());
        }
        assert!(worst < 4e-16, "e^y off by {worst:e} relative");
        assert_eq!(exp_bounded(0.0), 1.0);
        assert_eq!(exp_bounded(std::f64::consts::LN_2), 2.0);
        assert!(exp_bounded(f64::NAN).is_nan());
    }

    #[test]
    fn samples_side_by_side_give_the_bits_of_samples_one_by_one() {
        // Eleven samples as the fit passes them, a full chunk of lanes and a partial one of
        // three, in the processor's widest vectors (`wide`), against one lane each in the
        // plain build: the same outputs and the same gradient, bit for bit.
        let mut rng = Rng::new(11);
        let w: Vec<f64> = (0..N_WEIGHTS).map(|_| rng.uniform(-0.8, 0.8)).collect();
        let xs: Vec<[f64; N_IN]> = (0..LANES + 3)
            .map(|_| std::array::from_fn(|_| rng.uniform(-1.5, 1.5)))
            .collect();
        let dys: Vec<[f64; N_OUT]> = (0..LANES + 3)
            .map(|_| std::array::from_fn(|_| rng.uniform(-2.0, 2.0)))
            .collect();
        let (mut one, mut side) = (vec![0.0; N_WEIGHTS], vec![0.0; N_WEIGHTS]);
        let mut ys_one = Vec::new();
        crate::wide::narrow(|| {
            for (x, dy) in xs.iter().zip(&dys) {
                let mut cache = NetCache::default();
                ys_one.push(forward_raw(&w, *x, &mut cache));
                backward_raw(&w, &cache, *dy, &mut one);
            }
        });
        let mut ys_side = Vec::new();
        crate::wide::wide(
            #[inline(always)]
            || {
                for (xc, dc) in xs.chunks(LANES).zip(dys.chunks(LANES)) {
                    let x: [[f64; N_IN]; LANES] =
                        std::array::from_fn(|l| xc.get(l).copied().unwrap_or_default());
                    let dy: [[f64; LANES]; N_OUT] = std::array::from_fn(|k| {
                        std::array::from_fn(|l| dc.get(l).map_or(0.0, |d| d[k]))
                    });
                    let mut cache = NetCache::<LANES>::default();
                    let y = forward_lanes(&w, &x, &mut cache);
                    ys_side.extend((0..xc.len()).map(|l| [y[0][l], y[1][l]]));
                    backward_lanes(&w, &cache, &dy, xc.len(), &mut side);
                }
            },
        );
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&ys_one.concat()), bits(&ys_side.concat()));
        assert_eq!(bits(&one), bits(&side));
    }

    #[test]
    fn a_new_network_corrects_nothing() {
        let net = ResidualNet::new(7, [1.75, 1.0, 1.0], [5.0, 500.0]);
        assert_eq!(net.forward(1.2, 0.3, -0.5), [0.0, 0.0]);
    }

    #[test]
    fn the_network_is_held_at_the_edge_of_the_inputs_it_was_fitted_on() {
        // Fitted on loaded cars going up and empty ones coming down: a loaded car going down
        // is corrected as the fullest car seen going down, an up trip at an unseen
        // acceleration as the steepest one seen; inside the box nothing changes.
        let mut net = ResidualNet::new(5, [1.75, 1.0, 1.0], [5.0, 500.0]);
        let mut rng = Rng::new(9);
        for w in &mut net.weights {
            *w = rng.uniform(-0.8, 0.8);
        }
        let seen = [
            [1.5, 0.6, 0.4],
            [0.8, 0.2, -0.5],
            [-1.5, 0.0, 0.3],
            [-1.0, 0.1, -0.6],
            [0.0, 0.3, 0.0],
        ];
        let free = net.clone();
        net.domain = InputDomain::of(seen.into_iter());
        assert_eq!(net.forward(1.2, 0.4, 0.1), free.forward(1.2, 0.4, 0.1));
        assert_eq!(net.forward(-1.2, 0.8, 0.0), free.forward(-1.2, 0.1, 0.0));
        assert_eq!(net.forward(1.0, 0.3, 0.9), free.forward(1.0, 0.3, 0.4));
        assert_eq!(net.forward(0.0, 0.9, 0.0), free.forward(0.0, 0.3, 0.0));
        assert_ne!(net.forward(-1.2, 0.8, 0.0), free.forward(-1.2, 0.8, 0.0));
        assert!(InputDomain::of(std::iter::empty()).is_none());
        let mut bad = net.domain.clone().expect("a box");
        assert_eq!(bad.validate(), Ok(()));
        bad.boxes[2] = Some([[1.0, 0.5], [0.0, 1.0], [-1.0, 1.0]]);
        assert!(bad.validate().is_err(), "min > max");
        bad.boxes[2] = Some([[-0.5, 1.0], [0.0, 1.0], [-1.0, 1.0]]);
        assert!(bad.validate().is_err(), "a down speed in the up box");
    }

    #[test]
    fn backward_matches_central_differences() {
        let mut rng = Rng::new(3);
        let w: Vec<f64> = (0..N_WEIGHTS).map(|_| rng.uniform(-0.8, 0.8)).collect();
        let x = [0.7, 0.2, -0.4];
        let dy = [0.3, -1.1];
        let loss = |w: &[f64]| {
            let y = forward_raw(w, x, &mut NetCache::default());
            dy[0] * y[0] + dy[1] * y[1]
        };
        let mut cache = NetCache::default();
        forward_raw(&w, x, &mut cache);
        let mut grad = vec![0.0; N_WEIGHTS];
        backward_raw(&w, &cache, dy, &mut grad);
        for i in 0..N_WEIGHTS {
            let (mut wp, mut wm) = (w.clone(), w.clone());
            wp[i] += 1e-6;
            wm[i] -= 1e-6;
            let num = (loss(&wp) - loss(&wm)) / 2e-6;
            assert!(
                (num - grad[i]).abs() < 1e-7 * (1.0 + num.abs()),
                "weight {i}: {num} vs {}",
                grad[i]
            );
        }
    }
}
