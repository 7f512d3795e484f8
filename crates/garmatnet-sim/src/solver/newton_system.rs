//! The sparse 3n x 3n Newton system of the drape solver: its fixed block pattern (spring
//! pairs and diagonal blocks), the symbolic Cholesky analysis done once per topology (under
//! the cheaper of two fill-reducing orderings), and the numeric factorisation and solve done
//! once per Newton iteration, in double precision or as a single-precision factor whose
//! solves are refined in double precision ([`FactorPrecision`]).

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{LltError, LltRegularization};
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::traits::ComplexField;
use faer::{Conj, MatMut, Par, Side};
use garmatnet_core::{Mat3, Real};

use crate::error::{Error, Result};
use crate::solver::cloth_model::ClothModel;
use crate::solver::drape_settings::FactorPrecision;
use crate::solver::nested_dissection::nested_dissection;

/// Relative residual `|b - A x| / |b|` a refined single-precision solve must reach: far below
/// what a Newton direction needs (2.7–2.9 refinement solves per factorisation on T-shirt
/// walks), though errors this size still tip an unstable equilibrium that double precision
/// holds. Measured: at 1e-12 a sheet balanced on a sphere still slid off; at 1e-14 half the
/// factorisations fell back to double precision and the walk was slower than double.
const REFINED_TOLERANCE: Real = 1e-9;

/// Most refinement solves before a single-precision factor is given up for this matrix.
const MAX_REFINEMENTS: usize = 8;

/// Upper-triangle positions of a 3x3 diagonal block, in `(row, column)` order of the slots.
const DIAG_ENTRIES: [(usize, usize); 6] = [(0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2)];

/// The Newton matrix `M/h^2 + H` of one cloth topology in upper-triangle CSC form, with its
/// symbolic factorisation (fill-reducing ordering, elimination tree) and the current numeric
/// factor.
#[derive(Debug, Clone)]
pub(crate) struct NewtonSystem {
    dim: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// Per vertex, the value slots of its diagonal block's upper triangle ([`DIAG_ENTRIES`]).
    diag_slots: Vec<[usize; 6]>,
    /// Per spring, the slots of the off-diagonal block (rows of the smaller vertex index,
    /// columns of the larger), `3 * row + column`.
    spring_slots: Vec<[usize; 9]>,
    symbolic: Arc<SymbolicCholesky<usize>>,
    /// Whether the nested dissection (rather than minimum degree) ordering was kept.
    #[cfg_attr(not(test), expect(dead_code, reason = "read by the tests"))]
    dissection: bool,
    values: Vec<Real>,
    factor: Vec<Real>,
    /// The single-precision factor of `values` when [`FactorPrecision::Mixed`] produced it.
    factor32: Vec<f32>,
    /// Whether the current matrix is factored in `factor32` (else in `factor`).
    single: bool,
    /// What the mixed-precision path did so far (read by the tests).
    stats: MixedStats,
}

/// Counts of the factorisations and refinement solves a [`NewtonSystem`] made.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct MixedStats {
    /// Single-precision factorisations that succeeded.
    pub(crate) single_factors: usize,
    /// Double-precision factorisations (fallbacks included).
    pub(crate) double_factors: usize,
    /// Refinement solves in single precision.
    pub(crate) refinements: usize,
}

impl NewtonSystem {
    /// The pattern and symbolic analysis for `model`'s topology.
    pub(crate) fn new(model: &ClothModel) -> Result<Self> {
        let n = model.vertex_count();
        let mut lower: Vec<Vec<usize>> = vec![Vec::new(); n];
        for s in model.springs() {
            lower[s.a.max(s.b)].push(s.a.min(s.b));
        }
        for l in &mut lower {
            l.sort_unstable();
            l.dedup();
        }
        let dim = 3 * n;
        let mut col_ptr = Vec::with_capacity(dim + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for (v, neighbours) in lower.iter().enumerate() {
            for c in 0..3 {
                for &u in neighbours {
                    row_idx.extend([3 * u, 3 * u + 1, 3 * u + 2]);
                }
                row_idx.extend((0..=c).map(|r| 3 * v + r));
                col_ptr.push(row_idx.len());
            }
        }
        let diag_slots = (0..n)
            .map(|v| DIAG_ENTRIES.map(|(r, c)| col_ptr[3 * v + c] + 3 * lower[v].len() + r))
            .collect();
        let spring_slots = model
            .springs()
            .iter()
            .map(|s| {
                let (u, v) = (s.a.min(s.b), s.a.max(s.b));
                let k = lower[v]
                    .binary_search(&u)
                    .unwrap_or_else(|_| unreachable!("the pattern holds every spring"));
                std::array::from_fn(|e| col_ptr[3 * v + e % 3] + 3 * k + e / 3)
            })
            .collect();
        let pattern = SymbolicSparseColMatRef::new_checked(dim, dim, &col_ptr, None, &row_idx);
        // Two fill-reducing orderings, the one with the smaller factor kept: approximate
        // minimum degree, and nested dissection of the vertex graph with each vertex's three
        // unknowns kept together.
        let amd = symbolic_cholesky(pattern, SymmetricOrdering::Amd)?;
        let mut adjacency = vec![Vec::new(); n];
        for (v, neighbours) in lower.iter().enumerate() {
            for &u in neighbours {
                adjacency[v].push(u);
                adjacency[u].push(v);
            }
        }
        let forward: Vec<usize> = nested_dissection(&adjacency)
            .into_iter()
            .flat_map(|v| [3 * v, 3 * v + 1, 3 * v + 2])
            .collect();
        let mut inverse = vec![0; dim];
        for (k, &i) in forward.iter().enumerate() {
            inverse[i] = k;
        }
        let dissection = symbolic_cholesky(
            pattern,
            SymmetricOrdering::Custom(PermRef::new_checked(&forward, &inverse, dim)),
        )?;
        let (symbolic, dissection) = if dissection.len_val() < amd.len_val() {
            (dissection, true)
        } else {
            (amd, false)
        };
        Ok(Self {
            dim,
            values: vec![0.0; row_idx.len()],
            factor: vec![0.0; symbolic.len_val()],
            factor32: Vec::new(),
            single: false,
            stats: MixedStats::default(),
            col_ptr,
            row_idx,
            diag_slots,
            spring_slots,
            symbolic: Arc::new(symbolic),
            dissection,
        })
    }

    /// Non-zeros of the Cholesky factor (a measure of the factorisation's cost).
    pub(crate) fn factor_len(&self) -> usize {
        self.factor.len()
    }

    /// Writes the matrix from per-vertex diagonal blocks and per-spring coupling blocks
    /// (`-K_s` for spring `s`, with `K_s` symmetric), then factors it numerically in
    /// `precision`. A single-precision factorisation that fails (a pivot lost to rounding)
    /// falls back to double precision.
    pub(crate) fn factorize(
        &mut self,
        diagonal: &[Mat3],
        coupling: &[Mat3],
        precision: FactorPrecision,
    ) -> Result<()> {
        self.values.iter_mut().for_each(|v| *v = 0.0);
        for (block, slots) in diagonal.iter().zip(&self.diag_slots) {
            for (&(r, c), &slot) in DIAG_ENTRIES.iter().zip(slots) {
                self.values[slot] = block[(r, c)];
            }
        }
        for (block, slots) in coupling.iter().zip(&self.spring_slots) {
            for (e, &slot) in slots.iter().enumerate() {
                self.values[slot] += block[(e / 3, e % 3)];
            }
        }
        self.single = precision == FactorPrecision::Mixed && self.factorize_single();
        if self.single {
            self.stats.single_factors += 1;
            Ok(())
        } else {
            self.factorize_double()
        }
    }

    /// Factors `values` in single precision; false if the factorisation failed.
    fn factorize_single(&mut self) -> bool {
        let values: Vec<f32> = self.values.iter().map(|&v| v as f32).collect();
        let mut factor = std::mem::take(&mut self.factor32);
        factor.resize(self.symbolic.len_val(), 0.0);
        let factored = self.factor_into(&values, &mut factor).is_ok();
        self.factor32 = factor;
        factored
    }

    /// Factors `values` in double precision.
    fn factorize_double(&mut self) -> Result<()> {
        self.stats.double_factors += 1;
        self.single = false;
        let mut factor = std::mem::take(&mut self.factor);
        let factored = self.factor_into(&self.values, &mut factor);
        self.factor = factor;
        factored.map_err(|e| Error::Factorization(format!("{e:?}")))
    }

    /// The numeric Cholesky factorisation of this pattern's upper-triangle matrix with
    /// `values` into `factor`, in `T`'s precision.
    fn factor_into<T: ComplexField>(
        &self,
        values: &[T],
        factor: &mut [T],
    ) -> std::result::Result<(), LltError> {
        let pattern = SymbolicSparseColMatRef::new_checked(
            self.dim,
            self.dim,
            &self.col_ptr,
            None,
            &self.row_idx,
        );
        let mut buffer = MemBuffer::new(
            self.symbolic
                .factorize_numeric_llt_scratch::<T>(Par::Seq, Default::default()),
        );
        self.symbolic.factorize_numeric_llt(
            factor,
            SparseColMatRef::new(pattern, values),
            Side::Upper,
            LltRegularization::default(),
            Par::Seq,
            MemStack::new(&mut buffer),
            Default::default(),
        )?;
        Ok(())
    }

    /// Solves `A x = rhs` in place with the current factor (`rhs` has `3n` entries, vertex
    /// `i`'s x, y, z at `3i`, `3i + 1`, `3i + 2`). With a single-precision factor the solution
    /// is refined against the double-precision matrix until its relative residual is below
    /// [`REFINED_TOLERANCE`]; if refinement stalls, the matrix is refactored in double
    /// precision and solved directly.
    pub(crate) fn solve(&mut self, rhs: &mut [Real]) -> Result<()> {
        if self.single {
            if self.solve_refined(rhs) {
                return Ok(());
            }
            self.factorize_double()?;
        }
        let mut buffer = MemBuffer::new(self.symbolic.solve_in_place_scratch::<Real>(1, Par::Seq));
        let llt = LltRef::new(&self.symbolic, &self.factor);
        let rhs = MatMut::from_column_major_slice_mut(rhs, self.dim, 1);
        llt.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut buffer));
        Ok(())
    }

    /// Iterative refinement with the single-precision factor: `x += A32^-1 (b - A x)` until
    /// the relative residual is below [`REFINED_TOLERANCE`]. On success `rhs` holds `x`; on
    /// a stall (residual not halving, or [`MAX_REFINEMENTS`] used) `rhs` is left as it was
    /// and false is returned.
    fn solve_refined(&mut self, rhs: &mut [Real]) -> bool {
        let mut buffer = MemBuffer::new(self.symbolic.solve_in_place_scratch::<f32>(1, Par::Seq));
        let llt = LltRef::new(&self.symbolic, &self.factor32);
        let norm_b = norm(rhs);
        if norm_b == 0.0 {
            return true;
        }
        let mut x = vec![0.0; self.dim];
        let mut residual = rhs.to_vec();
        let mut correction = vec![0.0_f32; self.dim];
        let mut previous = norm_b;
        for _ in 0..MAX_REFINEMENTS {
            for (c, &r) in correction.iter_mut().zip(&residual) {
                *c = r as f32;
            }
            llt.solve_in_place_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(&mut correction, self.dim, 1),
                Par::Seq,
                MemStack::new(&mut buffer),
            );
            self.stats.refinements += 1;
            for (xi, &c) in x.iter_mut().zip(&correction) {
                *xi += Real::from(c);
            }
            self.residual(rhs, &x, &mut residual);
            let current = norm(&residual);
            if !current.is_finite() || current > 0.5 * previous {
                return false;
            }
            if current <= REFINED_TOLERANCE * norm_b {
                rhs.copy_from_slice(&x);
                return true;
            }
            previous = current;
        }
        false
    }

    /// `out = b - A x` with the double-precision matrix (upper triangle stored).
    fn residual(&self, b: &[Real], x: &[Real], out: &mut [Real]) {
        out.copy_from_slice(b);
        for col in 0..self.dim {
            let range = self.col_ptr[col]..self.col_ptr[col + 1];
            let (mut sum, xc) = (0.0, x[col]);
            for (&row, &a) in self.row_idx[range.clone()].iter().zip(&self.values[range]) {
                if row == col {
                    sum += a * xc;
                } else {
                    out[row] -= a * xc;
                    sum += a * x[row];
                }
            }
            out[col] -= sum;
        }
    }
}

/// Euclidean norm.
fn norm(v: &[Real]) -> Real {
    v.iter().map(|x| x * x).sum::<Real>().sqrt()
}

/// The symbolic Cholesky analysis of the upper-triangle `pattern` under `ordering`.
fn symbolic_cholesky(
    pattern: SymbolicSparseColMatRef<'_, usize>,
    ordering: SymmetricOrdering<'_, usize>,
) -> Result<SymbolicCholesky<usize>> {
    factorize_symbolic_cholesky(
        pattern,
        Side::Upper,
        ordering,
        CholeskySymbolicParams::default(),
    )
    .map_err(|e| Error::Factorization(format!("{e:?}")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::cloth_model::SpringSpec;
    use approx::assert_relative_eq;
    use garmatnet_core::{CapsuleBody, Garment, Material, Resolution, Vec3};

    use crate::solver::cloth_model::cloth_from_garment;

    /// The T-shirt's cloth model of Cotton Poplin at `resolution`.
    fn tshirt(resolution: Resolution) -> ClothModel {
        let body = CapsuleBody::smpl_neutral();
        let garment = Garment::tshirt(resolution, &body).unwrap();
        cloth_from_garment(&garment, &Material::preset("Cotton Poplin").unwrap()).unwrap()
    }

    #[test]
    fn nested_dissection_is_kept_where_it_factors_cheaper() {
        // Measured: 2.49 M factor entries against minimum degree's 2.90 M at paper
        // resolution (factorisation 29 vs 38 ms); at default resolution minimum degree wins
        // narrowly (1.51 vs 1.56 M) and is kept, so default-resolution drapes are unchanged.
        // Measured on the boxy shirt, whose default-resolution drapes must not change
        // (revision 2's datasets, which the models shipped up to version 0.3 learned).
        let boxy = |resolution| {
            let body = CapsuleBody::smpl_neutral();
            let garment = Garment::boxy_tshirt(resolution, &body).unwrap();
            cloth_from_garment(&garment, &Material::preset("Cotton Poplin").unwrap()).unwrap()
        };
        let paper = NewtonSystem::new(&boxy(Resolution::Paper)).unwrap();
        assert!(paper.dissection);
        assert!(paper.factor_len() < 2_700_000, "{}", paper.factor_len());
        assert!(
            !NewtonSystem::new(&boxy(Resolution::Default))
                .unwrap()
                .dissection
        );
        // The fitted shirt at paper resolution factors cheaper with nested dissection too.
        assert!(
            NewtonSystem::new(&tshirt(Resolution::Paper))
                .unwrap()
                .dissection
        );
    }

    /// `A x` for the matrix held in `system.values`.
    fn times(system: &NewtonSystem, x: &[Real]) -> Vec<Real> {
        let mut minus = vec![0.0; x.len()];
        system.residual(&vec![0.0; x.len()], x, &mut minus);
        minus.iter().map(|v| -v).collect()
    }

    /// The paper T-shirt's mass-plus-stiffness matrix (as Newton assembles it at pseudo time
    /// step 0.1 s), factored in `precision`, and a right-hand side with a known solution,
    /// computed from the blocks (so a slot mix-up in the assembly cannot hide); the matrix
    /// product the refinement uses must agree with it.
    fn tshirt_system(precision: FactorPrecision) -> (NewtonSystem, Vec<Real>, Vec<Real>) {
        let model = tshirt(Resolution::Paper);
        let mut system = NewtonSystem::new(&model).unwrap();
        let n = model.vertex_count();
        let mut diagonal: Vec<Mat3> = model
            .masses()
            .iter()
            .map(|m| Mat3::identity() * (m / 0.01))
            .collect();
        let coupling: Vec<Mat3> = model
            .springs()
            .iter()
            .map(|s| {
                let k = Mat3::identity() * s.stiffness;
                diagonal[s.a] += k;
                diagonal[s.b] += k;
                -k
            })
            .collect();
        system.factorize(&diagonal, &coupling, precision).unwrap();
        let x: Vec<Real> = (0..3 * n)
            .map(|i| ((i * 7919) % 1000) as Real / 500.0 - 1.0)
            .collect();
        let mut b = vec![0.0; 3 * n];
        let block = |b: &mut [Real], row: usize, m: &Mat3, col: usize| {
            for r in 0..3 {
                for c in 0..3 {
                    b[3 * row + r] += m[(r, c)] * x[3 * col + c];
                }
            }
        };
        for (v, d) in diagonal.iter().enumerate() {
            block(&mut b, v, d, v);
        }
        for (s, k) in model.springs().iter().zip(&coupling) {
            block(&mut b, s.a, k, s.b);
            block(&mut b, s.b, k, s.a);
        }
        for (got, want) in times(&system, &x).iter().zip(&b) {
            assert_relative_eq!(*got, *want, epsilon = 1e-9, max_relative = 1e-12);
        }
        (system, x, b)
    }

    #[test]
    fn solves_the_tshirt_system_under_its_ordering() {
        // Whatever ordering was kept, the solve must invert the matrix: to within rounding
        // with a double factor; with a refined single one, to within the refinement's
        // residual (1e-9 relative) times the condition number.
        for (precision, epsilon) in [
            (FactorPrecision::Double, 1e-8),
            (FactorPrecision::Mixed, 1e-3),
        ] {
            let (mut system, x, mut b) = tshirt_system(precision);
            system.solve(&mut b).unwrap();
            for (got, want) in b.iter().zip(&x) {
                assert_relative_eq!(*got, *want, epsilon = epsilon);
            }
        }
    }

    #[test]
    fn mixed_precision_factors_in_single_precision_and_refines() {
        let (mut system, _, mut b) = tshirt_system(FactorPrecision::Mixed);
        let norm_b = norm(&b);
        let rhs = b.clone();
        system.solve(&mut b).unwrap();
        let mut residual = vec![0.0; b.len()];
        system.residual(&rhs, &b, &mut residual);
        assert!(norm(&residual) <= REFINED_TOLERANCE * norm_b);
        let stats = system.stats;
        assert_eq!((stats.single_factors, stats.double_factors), (1, 0));
        // One single-precision solve alone is not that accurate: refinement did work.
        assert!(stats.refinements >= 2, "{stats:?}");
    }

    #[test]
    fn mixed_precision_falls_back_to_double_on_an_ill_conditioned_matrix() {
        // The spring chain with almost no mass: condition number ~1e11, beyond what a
        // single-precision factor can refine (or even factor).
        let model = chain();
        let tiny = 1e-10;
        let diagonal = [
            Mat3::identity() * (2.0 + tiny),
            Mat3::identity() * (5.0 + tiny),
            Mat3::identity() * (3.0 + tiny),
        ];
        let coupling = [Mat3::identity() * -2.0, Mat3::identity() * -3.0];
        // A load that pulls the chain's ends apart unevenly, so the solution lies far along
        // the chain's (almost free) translation.
        let rhs = [1.0, -2.0, 0.5, 0.0, 1.0, 3.0, 2.0, 0.0, -1.0];
        let solve = |precision| {
            let mut system = NewtonSystem::new(&model).unwrap();
            system.factorize(&diagonal, &coupling, precision).unwrap();
            let mut x = rhs.to_vec();
            system.solve(&mut x).unwrap();
            (x, system.stats)
        };
        let (mixed, stats) = solve(FactorPrecision::Mixed);
        let (double, _) = solve(FactorPrecision::Double);
        assert_eq!(stats.double_factors, 1, "{stats:?}");
        assert!(mixed.iter().any(|v| v.abs() > 1e6), "{mixed:?}");
        assert_eq!(mixed, double);
    }

    /// Three vertices in a row joined by springs of stiffness 2 and 3.
    fn chain() -> ClothModel {
        let x = [Vec3::zeros(), Vec3::x(), 2.0 * Vec3::x()];
        let springs = [
            SpringSpec {
                a: 1,
                b: 0,
                rest_length: 1.0,
                stiffness: 2.0,
            },
            SpringSpec {
                a: 1,
                b: 2,
                rest_length: 1.0,
                stiffness: 3.0,
            },
        ];
        ClothModel::new(&x, &springs, &[1.0; 3]).unwrap()
    }

    #[test]
    fn solves_a_small_spring_chain_exactly() {
        let model = chain();
        let mut system = NewtonSystem::new(&model).unwrap();
        // A = diag(1 + sum k) on each block, -k I coupling: a discrete Laplacian plus mass.
        let diagonal = [
            Mat3::identity() * 3.0,
            Mat3::identity() * 6.0,
            Mat3::identity() * 4.0,
        ];
        let coupling = [Mat3::identity() * -2.0, Mat3::identity() * -3.0];
        system
            .factorize(&diagonal, &coupling, FactorPrecision::Double)
            .unwrap();
        let expected = [1.0, -2.0, 0.5, 0.0, 1.0, 3.0, 2.0, 0.0, -1.0];
        let mut rhs = vec![0.0; 9];
        for c in 0..3 {
            let e = |v: usize| expected[3 * v + c];
            rhs[c] = 3.0 * e(0) - 2.0 * e(1);
            rhs[3 + c] = 6.0 * e(1) - 2.0 * e(0) - 3.0 * e(2);
            rhs[6 + c] = 4.0 * e(2) - 3.0 * e(1);
        }
        system.solve(&mut rhs).unwrap();
        for (got, want) in rhs.iter().zip(expected) {
            assert_relative_eq!(*got, want, epsilon = 1e-12);
        }
    }
}
