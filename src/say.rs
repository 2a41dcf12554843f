//! `say!` and `tell!`: printing that survives a closed pipe or a full disk
//! (both crates of the package include this file).

/// println! that ignores a failed write (a closed pipe, a full disk) instead
/// of panicking: the exit status and the files written still tell.
#[allow(unused_macros)]
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($t)*);
    }};
}

/// eprintln! that ignores a failed write, as [`say!`].
#[allow(unused_macros)]
macro_rules! tell {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}
