//! The hot kernels compiled twice: for the baseline x86-64 the binary is
//! built for, and for AVX2 (256-bit vectors), taken at run time where the
//! processor has it (`is_x86_feature_detected!`, a cached flag). The results
//! are the same to the bit: Rust never fuses a multiply and an add nor
//! reorders a sum, so the wider code does the same operations in the same
//! order, four lanes at a time where a loop allows.
//!
//! `wide_method!(fn NAME = KERNEL / AVX2 (&self, args) -> R)` defines NAME,
//! which calls the `#[inline(always)]` method KERNEL through AVX2, a copy of
//! it compiled with the feature enabled, where the processor has it;
//! `wide_fn!` the same for a free function.

macro_rules! wide_method {
    ($(#[$m:meta])* $vis:vis fn $name:ident = $kernel:ident / $avx:ident
     (&mut $self_:ident $(, $arg:ident : $ty:ty)* $(,)?) $(-> $ret:ty)?) => {
        $crate::solver::wide::wide_method!(@emit [$(#[$m])*] [$vis] $name $kernel $avx
            [&mut $self_] $self_ [$($arg: $ty),*] [$(-> $ret)?]);
    };
    ($(#[$m:meta])* $vis:vis fn $name:ident = $kernel:ident / $avx:ident
     (&$self_:ident $(, $arg:ident : $ty:ty)* $(,)?) $(-> $ret:ty)?) => {
        $crate::solver::wide::wide_method!(@emit [$(#[$m])*] [$vis] $name $kernel $avx
            [&$self_] $self_ [$($arg: $ty),*] [$(-> $ret)?]);
    };
    (@emit [$($m:tt)*] [$vis:vis] $name:ident $kernel:ident $avx:ident [$($recv:tt)*]
     $self_:ident [$($arg:ident : $ty:ty),*] [$($ret:tt)*]) => {
        $($m)*
        $vis fn $name($($recv)* $(, $arg: $ty)*) $($ret)* {
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the processor has AVX2 (detected just above)
                return unsafe { $self_.$avx($($arg),*) };
            }
            $self_.$kernel($($arg),*)
        }

        /// The kernel compiled for AVX2; the caller checks that the
        /// processor has it.
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2")]
        unsafe fn $avx($($recv)* $(, $arg: $ty)*) $($ret)* {
            $self_.$kernel($($arg),*)
        }
    };
}

macro_rules! wide_fn {
    ($(#[$m:meta])* $vis:vis fn $name:ident = $kernel:ident / $avx:ident
     ($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)?) => {
        $(#[$m])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the processor has AVX2 (detected just above)
                return unsafe { $avx($($arg),*) };
            }
            $kernel($($arg),*)
        }

        /// The kernel compiled for AVX2; the caller checks that the
        /// processor has it.
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2")]
        unsafe fn $avx($($arg: $ty),*) $(-> $ret)? {
            $kernel($($arg),*)
        }
    };
}

pub(crate) use {wide_fn, wide_method};

#[cfg(test)]
mod tests {
    /// Sums and recurrences whose order matters in floating point.
    #[inline(always)]
    fn kernel(a: &[f64], b: &[f64], y: &mut [f64]) -> f64 {
        let mut s = 0.0;
        for i in 0..a.len() {
            s += a[i] * b[i];
            y[i] = a[i] * b[i] + 0.1 * if i > 0 { y[i - 1] } else { 0.0 };
        }
        s
    }

    wide_fn!(fn wide_kernel = kernel / kernel_avx2 (a: &[f64], b: &[f64], y: &mut [f64]) -> f64);

    /// The dispatched kernel computes what the baseline one does, to the
    /// bit, whichever path this processor takes.
    #[test]
    fn the_wide_kernel_gives_the_baseline_bits() {
        let a: Vec<f64> = (0..1003)
            .map(|i| ((i * 7919) % 1009) as f64 / 3.0 - 150.0)
            .collect();
        let b: Vec<f64> = (0..1003).map(|i| 1.0 / (1.0 + i as f64)).collect();
        let (mut y0, mut y1) = (vec![0.0; a.len()], vec![0.0; a.len()]);
        let s0 = kernel(&a, &b, &mut y0);
        let s1 = wide_kernel(&a, &b, &mut y1);
        assert_eq!(s0.to_bits(), s1.to_bits());
        assert!(y0.iter().zip(&y1).all(|(p, q)| p.to_bits() == q.to_bits()));
    }
}
