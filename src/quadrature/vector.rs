//! Node loops compiled for the widest vector unit the CPU has, with the bits of the baseline.
//!
//! A [`Kernel`] is a loop over quadrature nodes written without branches or calls (selects
//! only, polynomial exponentials, one division and a few square roots per node), so that it
//! vectorises. [`run`] compiles it three times — for AVX-512, AVX2 and the x86-64 baseline
//! (SSE2) — and picks the widest the CPU supports at run time. Rust does not contract `a·b + c`
//! into a fused multiply–add, so every build performs the same IEEE operations in the same
//! order, and a table does not depend on the machine that computed it (each kernel's tests
//! compare [`Kernel::run`] with [`run`] bit for bit).

/// Nodes a kernel evaluates side by side: one AVX-512 register of f64, two AVX2 ones.
pub const LANES: usize = 8;

/// A node loop to run on the widest vector unit ([`run`]).
pub trait Kernel {
    type Output;
    /// The loop itself. Implementations mark it `#[inline(always)]`, so that it is compiled
    /// inside each of [`run`]'s target-feature functions.
    fn run(&mut self) -> Self::Output;
    /// The loop for a vector unit of 256 bits or less (AVX2, and the SSE2 baseline): by
    /// default [`Self::run`]. A kernel whose blocks of [`LANES`] nodes hold more values than
    /// those units have registers may use narrower blocks here, with the same arithmetic per
    /// node (and so the same bits).
    #[inline(always)]
    fn run_narrow(&mut self) -> Self::Output {
        self.run()
    }
}

/// Runs `kernel` compiled for AVX-512 or AVX2 where the CPU has them, else for the baseline.
#[inline]
pub fn run<K: Kernel>(mut kernel: K) -> K::Output {
    #[cfg(test)]
    if BASELINE_ONLY.with(std::cell::Cell::get) {
        return baseline(&mut kernel);
    }
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx512f")]
        unsafe fn avx512<K: Kernel>(kernel: &mut K) -> K::Output {
            kernel.run()
        }
        #[target_feature(enable = "avx2")]
        unsafe fn avx2<K: Kernel>(kernel: &mut K) -> K::Output {
            kernel.run_narrow()
        }
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F (checked just above).
            return unsafe { avx512(&mut kernel) };
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (checked just above).
            return unsafe { avx2(&mut kernel) };
        }
    }
    baseline(&mut kernel)
}

/// The baseline build, out of line like the others (so that the dispatch stays small).
#[inline(never)]
fn baseline<K: Kernel>(kernel: &mut K) -> K::Output {
    kernel.run_narrow()
}

#[cfg(test)]
thread_local! {
    /// Set by [`on_baseline`]: every [`run`] on this thread takes the baseline build.
    static BASELINE_ONLY: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `f` with every [`run`] on this thread compiled for the baseline (SSE2), so that a test
/// can compare whole integrals from the baseline and the wide builds bit for bit.
#[cfg(test)]
pub fn on_baseline<T>(f: impl FnOnce() -> T) -> T {
    BASELINE_ONLY.with(|b| b.set(true));
    let out = f();
    BASELINE_ONLY.with(|b| b.set(false));
    out
}

/// An integrand evaluated at [`LANES`] nodes at once, `C` channels per node: the body of a
/// [`WeightedSum`]. Implementations mark `block` `#[inline(always)]` (a closure would not be
/// inlined into [`run`]'s target-feature functions, and would run on the baseline unit).
pub trait Block<const C: usize> {
    fn block(&self, v: &[f64; LANES]) -> [[f64; C]; LANES];
}

/// Σ_j ws[j]·y_c(vs[j]) per channel c, in node order, `LANES` nodes per [`Block::block`] (lanes
/// past the end of `vs` repeat its first node; their values are discarded): a [`Kernel`].
pub struct WeightedSum<'a, B, const C: usize> {
    pub block: B,
    pub vs: &'a [f64],
    pub ws: &'a [f64],
}

impl<const C: usize, B: Block<C>> Kernel for WeightedSum<'_, B, C> {
    type Output = [f64; C];
    #[inline(always)]
    fn run(&mut self) -> [f64; C] {
        let mut sum = [0.0; C];
        for (vc, wc) in self.vs.chunks(LANES).zip(self.ws.chunks(LANES)) {
            let mut v = [vc[0]; LANES];
            v[..vc.len()].copy_from_slice(vc);
            let y = self.block.block(&v);
            for (yj, &w) in y.iter().zip(wc) {
                for (s, &yc) in sum.iter_mut().zip(yj) {
                    *s += w * yc;
                }
            }
        }
        sum
    }
}
