//! The assembled constraint system of the active element set: residual Phi,
//! Jacobian A (block-sparse: each element writes a dense block over its own
//! joints) and the convective term Adot Xdot. The pattern is built once per
//! change of the locked set; `fill` only rewrites values.

use super::model::Model;

#[derive(Clone, Debug)]
pub struct Block {
    pub element: usize,
    pub row0: usize,
    pub rows: usize,
    /// First column of each of the element's joints (3 * joint index).
    pub cols: Vec<usize>,
    /// Offset of the block's row-major values in `Jacobian::values`.
    pub offset: usize,
}

#[derive(Clone, Debug, Default)]
pub struct Jacobian {
    pub nrows: usize,
    pub ncols: usize,
    pub blocks: Vec<Block>,
    pub values: Vec<f64>,
    /// Names the block structure: a fresh number per `pattern()`, shared by
    /// clones (0: unnamed, compared block by block). Solvers key their
    /// symbolic analysis on it.
    pub structure_id: u64,
    /// The rows as the joint triples they touch (`Constraint::row_touches`;
    /// the blocks are stored row after row, dense): row i's triples are
    /// `row_triples[i]..row_triples[i + 1]`, triple t is
    /// `values[triple_val[t]..triple_val[t] + 3]` over the columns from
    /// `triple_cols[t]`.
    row_triples: Vec<u32>,
    triple_cols: Vec<u32>,
    triple_val: Vec<u32>,
    /// Per dense triple of the blocks (values / 3, in storage order): whether
    /// its row touches that joint (the others hold zeros).
    touched: Vec<bool>,
}

static NEXT_STRUCTURE_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

impl Jacobian {
    pub fn pattern(model: &Model, locked: &[bool]) -> Jacobian {
        let mut blocks = Vec::new();
        let (mut row0, mut offset) = (0, 0);
        for (e, el) in model.elements.iter().enumerate() {
            let rows = el.rows(locked[e]);
            if rows == 0 {
                continue;
            }
            let cols: Vec<usize> = el.joints().iter().map(|j| 3 * j).collect();
            blocks.push(Block {
                element: e,
                row0,
                rows,
                offset,
                cols,
            });
            offset += rows * 3 * el.joints().len();
            row0 += rows;
        }
        // (`Model::build` refuses a model whose Jacobian could pass u32's
        // range with any locked set: an invariant, not an input check)
        assert!(offset <= u32::MAX as usize, "Jacobian of {offset} entries");
        let (mut row_triples, mut triple_cols) = (vec![0u32], Vec::with_capacity(offset / 3));
        let (mut triple_val, mut touched) = (Vec::with_capacity(offset / 3), Vec::new());
        for b in &blocks {
            let el = &model.elements[b.element];
            for r in 0..b.rows {
                for (jj, &c) in b.cols.iter().enumerate() {
                    let touches = el.row_touches(locked[b.element], r, jj);
                    touched.push(touches);
                    if touches {
                        triple_cols.push(c as u32);
                        triple_val.push((b.offset + (r * b.cols.len() + jj) * 3) as u32);
                    }
                }
                row_triples.push(triple_cols.len() as u32);
            }
        }
        Jacobian {
            nrows: row0,
            ncols: model.n_coords(),
            blocks,
            values: vec![0.0; offset],
            structure_id: NEXT_STRUCTURE_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            row_triples,
            triple_cols,
            triple_val,
            touched,
        }
    }

    /// Whether row `r` of block `b` touches the block's joint `jj` (its
    /// entries there are zero at every configuration when not).
    pub fn touches(&self, b: &Block, r: usize, jj: usize) -> bool {
        self.touched[b.offset / 3 + r * b.cols.len() + jj]
    }

    /// Width of a block's rows (3 per joint).
    #[inline]
    pub fn width(b: &Block) -> usize {
        3 * b.cols.len()
    }

    /// The most entries an element's block holds: its larger row count,
    /// locked or unlocked, times 3 per joint (`Model::build`'s size check).
    pub fn most_entries(el: &dyn super::elements::Constraint) -> usize {
        el.rows(true).max(el.rows(false)) * 3 * el.joints().len()
    }

    pub fn fill(&mut self, model: &Model, x: &[f64]) {
        for b in &self.blocks {
            let w = Self::width(b);
            let vals = &mut self.values[b.offset..b.offset + b.rows * w];
            vals.fill(0.0);
            model.elements[b.element].jacobian(x, vals);
        }
        debug_assert!(
            self.values
                .chunks_exact(3)
                .zip(&self.touched)
                .all(|(v, &t)| t || v == [0.0; 3]),
            "an element wrote an entry where its row_touches says none is"
        );
    }

    /// The element of the first block with a non-finite value, and how many
    /// blocks have one (for the error that names it: after a diverged
    /// iteration most blocks do, and the first is not the cause).
    pub fn non_finite_element(&self) -> Option<(usize, usize)> {
        let mut bad = self.blocks.iter().filter(|b| {
            self.values[b.offset..b.offset + b.rows * Self::width(b)]
                .iter()
                .any(|v| !v.is_finite())
        });
        let first = bad.next()?.element;
        Some((first, 1 + bad.count()))
    }

    /// Where the Jacobian is not finite, for an error message: the element
    /// whose rows hold the first non-finite entry (and its joints), or how
    /// many elements do, or the products where every entry is finite.
    pub fn describe_non_finite(&self, model: &Model) -> String {
        match self.non_finite_element() {
            Some((e, 1)) => format!(
                "constraint Jacobian, in the rows of {} `{}` (joints {})",
                model.elements[e].kind(),
                model.elements[e].name(),
                model.elements[e]
                    .joints()
                    .iter()
                    .map(|&j| model.joints[j].name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            Some((e, n)) => format!(
                "constraint Jacobian, in the rows of {n} elements, the first {} `{}` \
                 (the iteration diverged)",
                model.elements[e].kind(),
                model.elements[e].name()
            ),
            // (finite entries whose products overflowed)
            None => "constraint Jacobian's products (its entries overflowed: the \
                     iteration diverged)"
                .to_string(),
        }
    }

    pub fn residual(&self, model: &Model, x: &[f64], out: &mut [f64]) {
        for b in &self.blocks {
            model.elements[b.element].residual(x, &mut out[b.row0..b.row0 + b.rows]);
        }
    }

    pub fn adot_xdot(&self, model: &Model, x: &[f64], v: &[f64], out: &mut [f64]) {
        for b in &self.blocks {
            model.elements[b.element].adot_xdot(x, v, &mut out[b.row0..b.row0 + b.rows]);
        }
    }

    /// Calls f(row, col, value) for every stored entry.
    pub fn for_each(&self, mut f: impl FnMut(usize, usize, f64)) {
        for b in &self.blocks {
            let w = Self::width(b);
            for r in 0..b.rows {
                for (jj, &c0) in b.cols.iter().enumerate() {
                    for k in 0..3 {
                        f(
                            b.row0 + r,
                            c0 + k,
                            self.values[b.offset + r * w + 3 * jj + k],
                        );
                    }
                }
            }
        }
    }

    crate::solver::wide::wide_method!(
        /// out = A v
        pub fn mul = mul_kernel / mul_avx2 (&self, v: &[f64], out: &mut [f64])
    );

    #[inline(always)]
    fn mul_kernel(&self, v: &[f64], out: &mut [f64]) {
        if self.nrows == 0 {
            return;
        }
        let (vals, cols, rows, at) = (
            &self.values,
            &self.triple_cols,
            &self.row_triples,
            &self.triple_val,
        );
        assert!(out.len() >= self.nrows && v.len() >= self.ncols);
        assert!(rows.len() == self.nrows + 1 && 3 * self.touched.len() == vals.len());
        for (i, o) in out[..self.nrows].iter_mut().enumerate() {
            let mut sum = 0.0;
            for t in rows[i] as usize..rows[i + 1] as usize {
                // SAFETY: t < cols.len() = at.len() (row_triples ends at
                // it), at[t] + 2 < vals.len() (a triple of the blocks, whose
                // size is asserted), c + 2 < ncols <= v.len() (the columns
                // of a joint's triple)
                unsafe {
                    let c = *cols.get_unchecked(t) as usize;
                    let p = *at.get_unchecked(t) as usize;
                    let a = vals.get_unchecked(p..p + 3);
                    let x = v.get_unchecked(c..c + 3);
                    sum += a[0] * x[0] + a[1] * x[1] + a[2] * x[2];
                }
            }
            *o = sum;
        }
    }

    crate::solver::wide::wide_method!(
        /// out = A^T y
        pub fn mul_t = mul_t_kernel / mul_t_avx2 (&self, y: &[f64], out: &mut [f64])
    );

    #[inline(always)]
    fn mul_t_kernel(&self, y: &[f64], out: &mut [f64]) {
        let (vals, cols, rows, at) = (
            &self.values,
            &self.triple_cols,
            &self.row_triples,
            &self.triple_val,
        );
        assert!(out.len() >= self.ncols && y.len() >= self.nrows);
        out[..self.ncols].fill(0.0);
        if self.nrows == 0 {
            return;
        }
        assert!(rows.len() == self.nrows + 1 && 3 * self.touched.len() == vals.len());
        for (i, &yr) in y[..self.nrows].iter().enumerate() {
            for t in rows[i] as usize..rows[i + 1] as usize {
                // SAFETY: as in `mul`
                unsafe {
                    let c = *cols.get_unchecked(t) as usize;
                    let p = *at.get_unchecked(t) as usize;
                    let a = vals.get_unchecked(p..p + 3);
                    let o = out.get_unchecked_mut(c..c + 3);
                    o[0] += a[0] * yr;
                    o[1] += a[1] * yr;
                    o[2] += a[2] * yr;
                }
            }
        }
    }

    pub fn to_dense(&self) -> nalgebra::DMatrix<f64> {
        let mut m = nalgebra::DMatrix::zeros(self.nrows, self.ncols);
        self.for_each(|r, c, a| m[(r, c)] += a);
        m
    }

    /// The first global row of an element's block; None where the element
    /// has no rows in the pattern (a sleeve not latched).
    pub fn first_row_of(&self, element: usize) -> Option<usize> {
        self.blocks
            .iter()
            .find(|b| b.element == element)
            .map(|b| b.row0)
    }

    /// The element and its local row for a global row.
    pub fn row_owner(&self, row: usize) -> (usize, usize) {
        let b = self
            .blocks
            .iter()
            .find(|b| row >= b.row0 && row < b.row0 + b.rows)
            .expect("row in range");
        (b.element, row - b.row0)
    }
}

#[cfg(test)]
mod tests {
    use super::Jacobian;
    use crate::model::generate::{self, MastParams};

    /// The element named for a non-finite Jacobian is the one whose block
    /// holds the value; none while every value is finite.
    #[test]
    fn a_non_finite_value_is_found_in_its_elements_block() {
        let text = generate::mast(&MastParams::default()).unwrap().to_toml();
        let m = crate::model::parse(&text, "mast.toml").unwrap().model;
        let mut jac = Jacobian::pattern(&m, &vec![false; m.elements.len()]);
        jac.fill(&m, &m.x0);
        assert_eq!(jac.non_finite_element(), None);
        let b = &jac.blocks[jac.blocks.len() / 2];
        let (element, at) = (b.element, b.offset + b.rows * Jacobian::width(b) - 1);
        jac.values[at] = f64::NAN;
        assert_eq!(jac.non_finite_element(), Some((element, 1)));
    }
}
