//! Run-time choice of the widest vector registers. The hot loops (Carlson's lanes, a curved
//! rate's Kronrod nodes, a panel's antiderivative, a path's Clenshaw reads) are plain loops
//! over arrays, summed in an order fixed in the code, with nothing fused; compiled for AVX-512
//! or AVX2 the compiler runs them eight or four lanes to a register, and since each lane does
//! exactly the portable build's operations, every build gives the same bits. The binary stays
//! portable: the features are detected when called (a cached flag), not assumed at compile
//! time. Written as plain loops they vectorise only when nothing in them is a branch per lane:
//! a lane that must stop early is frozen by a bitwise select, not an `if` (see `carlson.rs`).

/// Work to run in the widest build. `run` must be `#[inline(always)]`, as must what it calls,
/// so that all of it is compiled inside that build (a closure would be compiled on its own,
/// for the baseline, and only called from it).
pub trait Wide {
    type Output;
    fn run(self) -> Self::Output;
}

/// `work.run()`, compiled for AVX-512F where the CPU has it, else for AVX2, else as built.
#[inline(always)]
pub fn widest<W: Wide>(work: W) -> W::Output {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F, the only feature `avx512` is compiled for.
            return unsafe { avx512(work) };
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, the only feature `avx2` is compiled for.
            return unsafe { avx2(work) };
        }
    }
    work.run()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn avx512<W: Wide>(work: W) -> W::Output {
    work.run()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn avx2<W: Wide>(work: W) -> W::Output {
    work.run()
}

/// `[f(0), …, f(L − 1)]` in a plain loop, so that it is compiled inside the caller's build:
/// `std::array::from_fn` may be left a call of its own, compiled for the baseline (two lanes
/// to a register, out of line), in the middle of a wide build's lanes.
#[inline(always)]
pub fn lanes<T: Copy + Default, const L: usize>(f: impl Fn(usize) -> T) -> [T; L] {
    let mut out = [T::default(); L];
    for (l, value) in out.iter_mut().enumerate() {
        *value = f(l);
    }
    out
}
