"""The machinery behind the documented options, each against an independent path: the sparse
Cholesky against dense factorizations (its drop-tolerance path included), solver="kkt"
against the Schur complement, a user-written Method, the sparse path of a large model against
the dense one, and model-level thread safety."""
import threading

import numpy as np
import pytest

from spatialmbd import ModelBuilder, models
from spatialmbd.dynamics import sparse as spc
from spatialmbd.dynamics.base import Method, MethodOutput
from spatialmbd.dynamics.standard import Standard
from spatialmbd.simulate import simulate


def random_pattern(rng, n, density):
    A = (rng.uniform(size=(n, n)) < density).astype(float)
    A = np.maximum(A, A.T)
    np.fill_diagonal(A, 1.0)
    rows, cols = np.nonzero(np.triu(A))
    return rows, cols


def spd_on_pattern(rng, n, rows, cols):
    """An SPD matrix with exactly this pattern (off-diagonals random, diagonal dominant)."""
    A = np.zeros((n, n))
    vals = rng.normal(size=rows.size)
    A[rows, cols] = vals
    A[cols, rows] = vals
    np.fill_diagonal(A, np.abs(A).sum(axis=1) + rng.uniform(0.5, 2.0, size=n))
    return A


@pytest.mark.parametrize("n, density", [(5, 0.6), (40, 0.08), (120, 0.03)])
def test_sparse_cholesky_matches_dense_factorization(n, density):
    rng = np.random.default_rng(n)
    rows, cols = random_pattern(rng, n, density)
    sym = spc.SparseCholesky(n, rows, cols)
    for _ in range(3):
        A = spd_on_pattern(rng, n, rows, cols)
        Cx = np.zeros(sym.Ci.size)
        pos = sym.positions(rows, cols)
        Cx[pos] = A[rows, cols]
        assert np.allclose(sym.to_scipy(Cx).toarray(), A)
        Lx = np.zeros(sym.nnz_L)
        assert spc.numeric(sym.arrays(), Cx, Lx, np.zeros(n))
        b = rng.normal(size=n)
        x = b.copy()
        spc.solve(sym.arrays(), Lx, x, np.zeros(n))
        assert np.allclose(x, np.linalg.solve(A, b), rtol=1e-10, atol=1e-12)
        # the factor itself: L L^T = P A P^T
        L = np.zeros((n, n))
        for j in range(n):
            L[sym.Li[sym.Lp[j]:sym.Lp[j + 1]], j] = Lx[sym.Lp[j]:sym.Lp[j + 1]]
        P = A[np.ix_(sym.perm, sym.perm)]
        assert np.allclose(L @ L.T, P, rtol=1e-12, atol=1e-12)
    # an indefinite matrix on the same pattern is refused, not factorized
    A[0, 0] = -1.0
    Cx[sym.positions([0], [0])] = -1.0
    assert not spc.numeric(sym.arrays(), Cx, np.zeros(sym.nnz_L), np.zeros(n))


def test_symbolic_analysis_is_shared_by_equal_patterns():
    """spc.symbolic: one read-only SparseCholesky per pattern (two builds of one topology share
    it, with identical results); a different pattern gets its own."""
    rng = np.random.default_rng(7)
    rows, cols = random_pattern(rng, 30, 0.1)
    a = spc.symbolic(30, rows, cols)
    assert spc.symbolic(30, rows.copy(), cols.copy()) is a
    assert not a.perm.flags.writeable and not a.Li.flags.writeable
    i = int(np.nonzero(rows != cols)[0][-1])
    rows2, cols2 = rows.copy(), cols.copy()
    rows2[i], cols2[i] = cols[i], rows[i]                 # the same entry, other triangle
    assert spc.symbolic(30, rows2, cols2) is not a
    assert spc.symbolic(31, rows, cols) is not a
    model = models.slider_crank(driven=False)
    r1 = simulate(model.compile(), 0.2, output_step=0.1)
    r2 = simulate(model.compile(), 0.2, output_step=0.1)
    from spatialmbd.dynamics import EquationsOfMotion
    assert EquationsOfMotion(model.compile()).system.S is EquationsOfMotion(
        model.compile()).system.S
    np.testing.assert_array_equal(r1.q, r2.q)


def test_drop_tolerance_leaves_out_exactly_the_dependent_rows():
    """S = B B^T with rows 3 and 7 of B combinations of others: rank 8 of 10. factor() with a
    drop tolerance drops two rows, and the rows kept are independent and span the rest."""
    rng = np.random.default_rng(4)
    B = rng.normal(size=(10, 12))
    B[3] = B[0] - 2 * B[1]
    B[7] = 0.5 * B[2] + B[5]
    S = B @ B.T
    rows, cols = np.nonzero(np.triu(np.ones((10, 10))))
    sym = spc.SparseCholesky(10, rows, cols)
    Cx = np.zeros(sym.Ci.size)
    Cx[sym.positions(rows, cols)] = S[rows, cols]
    dropped = np.zeros(10, dtype=np.int64)
    count = spc.factor(sym.arrays(), Cx, np.zeros(sym.nnz_L), np.zeros(10), 1e-10, dropped)
    assert count == 2
    out = sym.perm[dropped == 1]
    kept = np.setdiff1d(np.arange(10), out)
    assert np.linalg.matrix_rank(B[kept]) == 8
    # each dropped row is a combination of the kept ones
    for r in out:
        coef = np.linalg.lstsq(B[kept].T, B[r], rcond=None)[0]
        assert np.allclose(B[kept].T @ coef, B[r], atol=1e-10)


def test_kkt_solver_agrees_with_the_schur_complement():
    model = models.slider_crank().compile()
    kw = dict(integrator="rk45", rtol=1e-10, atol=1e-12, output_step=0.05)
    a = simulate(model, 0.5, method=Standard(), **kw)
    b = simulate(model, 0.5, method=Standard(solver="kkt"), **kw)
    assert a.success and b.success
    assert np.abs(a.q - b.q).max() < 1e-9
    assert np.abs(a.lam - b.lam).max() < 1e-6 * max(1.0, np.abs(a.lam).max())


class DenseNullSpace(Method):
    """A user-written method: accelerations by the dense KKT system with NumPy's solver, and
    Baumgarte-free gamma -- written only against the documented Evaluation fields."""

    name = "dense_user"

    def accelerations(self, ev, t):
        D = ev.cv.D
        D = D.toarray() if hasattr(D, "toarray") else np.asarray(D)
        M = ev.M.dense()
        n, m = M.shape[0], D.shape[0]
        K = np.block([[M, -D.T], [D, np.zeros((m, m))]])
        sol = np.linalg.solve(K, np.concatenate([ev.g, ev.cv.gamma]))
        return MethodOutput(vdot=sol[:n], lam=sol[n:])


def test_a_user_written_method_runs_and_agrees():
    model = models.double_pendulum().compile()
    kw = dict(integrator="rk45", rtol=1e-10, atol=1e-12, output_step=0.05)
    ours = simulate(model, 0.5, method=DenseNullSpace(), **kw)
    ref = simulate(model, 0.5, method="standard", **kw)
    assert ours.success, ours.message
    assert np.abs(ours.q - ref.q).max() < 1e-8
    assert np.abs(ours.lam - ref.lam).max() < 1e-6 * np.abs(ref.lam).max()


def chain(n):
    b = ModelBuilder(f"chain{n}", gravity=(0, 0, -9.81))
    prev = "ground"
    for k in range(n):
        b.add_body(f"l{k}", 1.0, (0.01, 0.09, 0.09), r=(k + 0.5, 0, 0))
        b.add_joint("revolute" if k % 2 else "spherical", f"j{k}", prev, f"l{k}",
                    point=(k, 0, 0), axis=(0, 1, 0))
        prev = f"l{k}"
    return b.compile()


def test_large_model_sparse_path_matches_dense():
    model = chain(110)
    kw = dict(method="standard", integrator="rk4", step=1e-3, output_step=0.01)
    sp_ = simulate(model, 0.02, sparse=True, **kw)
    de = simulate(model, 0.02, sparse=False, **kw)
    assert sp_.success and de.success
    assert np.abs(sp_.q - de.q).max() < 1e-10
    assert np.abs(sp_.lam - de.lam).max() < 1e-7 * np.abs(de.lam).max()


def test_one_model_in_two_threads_gives_identical_results():
    """The Model is shared, every run has its own workspace: concurrent runs do not mix."""
    model = models.flyball_governor().compile()          # drivers-free, force elements
    crank = models.slider_crank(crank_speed=6.0).compile()
    runs = {}

    def run(key, m, method):
        runs[key] = simulate(m, 0.2, method=method, integrator="rk45", rtol=1e-8,
                             atol=1e-10, output_step=0.01)
    serial = {("fly", k): simulate(model, 0.2, method=k, integrator="rk45", rtol=1e-8,
                                   atol=1e-10, output_step=0.01)
              for k in ("standard", "penalty")}
    serial[("crank", "standard")] = simulate(crank, 0.2, method="standard", integrator="rk45",
                                             rtol=1e-8, atol=1e-10, output_step=0.01)
    threads = [threading.Thread(target=run, args=(("fly", k), model, k))
               for k in ("standard", "penalty")]
    threads.append(threading.Thread(target=run, args=(("crank", "standard"), crank,
                                                         "standard")))
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    for key, ref in serial.items():
        assert runs[key].success
        assert np.array_equal(runs[key].q, ref.q), key
        assert np.array_equal(runs[key].lam, ref.lam), key


def test_the_model_holds_no_workspace_and_kinematics_runs_in_threads():
    """Workspaces live in Data (one per thread unless make_data gives one explicitly): after
    analyses in two threads, neither the Model nor its element groups carry buffers, and each
    thread's kinematics equals the serial result."""
    from spatialmbd.kinematics import kinematic_analysis
    from spatialmbd.model import make_data
    from spatialmbd.model.data import thread_data
    model = models.slider_crank(crank_speed=6.0).compile()
    t = np.linspace(0.0, 1.0, 41)
    ref = kinematic_analysis(model, t)
    out = {}

    def run(k):
        out[k] = kinematic_analysis(model, t)
    threads = [threading.Thread(target=run, args=(k,)) for k in range(3)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    for k in range(3):
        assert np.array_equal(out[k].q, ref.q) and np.array_equal(out[k].vdot, ref.vdot)
    simulate(model, 0.05, output_step=0.01)
    derived = {"n_eq", "inertia_inverse", "equation_labels", "group_offsets"}
    assert set(vars(model)) - {f for f in model.__dataclass_fields__} <= derived
    for group in model.constraint_groups + model.force_groups:
        assert not [k for k in vars(group) if k.startswith("_") and "table" in k or k == "_last"]
    a, b = make_data(model), make_data(model)
    assert a.assembler is not b.assembler and thread_data(model) is thread_data(model)
