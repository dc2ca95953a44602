"""The first natural frequencies of a mixed model (solids and beams tied by joints), serially:
issue 33's "the first six frequencies within 3 %" of the mixed crane against the 3D mock-up
(`crane-fem modes` refuses mixed models: not built).

Each part's closed structure as `crane-fem modes` assembles it (crane_fem.modes.operators:
the free DOFs' K and consistent M, the touching contacts tied by k_p, the supports removed),
the joints' beam nodes eliminated by the rigid section's rows, (u_P, θ_P) =
diag(|S| 1, I_G)⁻¹ C u_S (as tests/test_joint.py), and K φ = ω² M φ solved by SciPy's
shift-and-invert Lanczos. Effective masses along x, y, z from the translations' influence
vectors. Writes benchmarks/out/mixed_modes.md.

    .venv/bin/python benchmarks/mixed_modes.py [SCENE] [--n 6] [--set KEY=VALUE ...]

SCENE defaults to demos/frame_crane_solid.toml.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from mpi4py import MPI

from crane_fem.coupling.rigid_section import face_rows
from crane_fem.modes.operators import ClosedStructure, assemble_closed_structure
from crane_fem.pipeline import build_mesh
from crane_fem.pipeline.kinds import concrete_scenario
from crane_fem.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "out"
SELF = MPI.COMM_SELF


def _csr(A) -> sp.csr_matrix:
    indptr, indices, data = A.getValuesCSR()
    return sp.csr_matrix((data, indices, indptr), shape=A.getSize())


def _face_facets(tagged, name: str) -> np.ndarray:
    return tagged.facet_tags.indices[tagged.facet_tags.values == tagged.facet_groups[name]]


def mixed_frequencies(scene: Path, sets: list[str], n: int) -> dict:
    sc = concrete_scenario(load_scenario(scene, sets), SELF)
    mesh = build_mesh(sc, SELF)
    assert mesh.beams is not None, "not a mixed model"
    mat = sc.materials[0][1]
    g = np.asarray(sc.loading.gravity, dtype=np.float64)
    parts: list[ClosedStructure] = [
        assemble_closed_structure(stage, mat.E, mat.nu, mat.rho, g) for stage in (mesh, mesh.beams)
    ]
    st_s, st_b = parts
    K_s, M_s, K_b, M_b = (_csr(A) for A in (st_s.K, st_s.M, st_b.K, st_b.M))
    n_s, n_b = K_s.shape[0], K_b.shape[0]
    free_s = {int(d): i for i, d in enumerate(st_s.free)}
    free_b = {int(d): i for i, d in enumerate(st_b.free)}
    beams = mesh.beams.tagged
    # The beam node's DOF block: its vertex's block in the beams' space.
    v_of_block = st_b.block_vertex
    rows_G, cols_G, vals_G, slaves = [], [], [], []
    for j in sc.joint:
        face = face_rows(st_s.V, _face_facets(mesh.tagged, j.face).astype(np.int32), j.label)
        node = int(beams.global_vertices(beams.facet_vertices(j.node))[0])
        blk = int(np.flatnonzero(v_of_block == node)[0])
        C = np.zeros((6, n_s))
        for r, d, c in zip(face.rows, face.dofs, face.coeffs, strict=True):
            if int(d) in free_s:  # (a clamped face DOF adds nothing)
                C[r, free_s[int(d)]] += c
        G = np.linalg.solve(face.beam_block, C)  # (u_P, θ_P) = B⁻¹ C u_S
        for k in range(6):
            slave = free_b[6 * blk + k]
            slaves.append(slave)
            nz = np.flatnonzero(G[k])
            rows_G += [slave] * nz.size
            cols_G += nz.tolist()
            vals_G += G[k, nz].tolist()
    slaves_a = np.asarray(slaves)
    keep_b = np.setdiff1d(np.arange(n_b), slaves_a)
    # T: q = (u_S free, u_b kept) -> (u_S, u_b).
    n_q = n_s + keep_b.size
    T_s = sp.hstack([sp.identity(n_s, format="csr"), sp.csr_matrix((n_s, keep_b.size))])
    T_b_keep = sp.csr_matrix(
        (np.ones(keep_b.size), (keep_b, n_s + np.arange(keep_b.size))), shape=(n_b, n_q)
    )
    T_b_slave = sp.csr_matrix((vals_G, (rows_G, cols_G)), shape=(n_b, n_q))
    T = sp.vstack([T_s, T_b_keep + T_b_slave]).tocsr()
    K = (T.T @ sp.block_diag([K_s, K_b]) @ T).tocsc()
    M = (T.T @ sp.block_diag([M_s, M_b]) @ T).tocsc()
    K = 0.5 * (K + K.T)
    M = 0.5 * (M + M.T)
    t0 = time.perf_counter()
    w2, phi = spla.eigsh(K, k=n, M=M, sigma=0.0, which="LM")
    order = np.argsort(w2)
    w2, phi = w2[order], phi[:, order]
    f = np.sqrt(np.maximum(w2, 0.0)) / (2 * np.pi)
    # Influence vectors of the translations (the beams' translation DOFs, the solids' all).
    total = []
    eff = np.zeros((n, 3))
    for c in range(3):
        r_s = np.zeros(n_s)
        comp_s = st_s.free % 3 == c
        r_s[comp_s] = 1.0
        r_b = np.zeros(n_b)
        r_b[st_b.free % 6 == c] = 1.0
        r = np.concatenate([r_s, r_b])
        # r lies in the range of T (a rigid translation meets the joints): its q.
        q = np.concatenate([r_s, r_b[keep_b]])
        Mr = M @ q
        total.append(float(q @ Mr))
        gamma = phi.T @ Mr
        eff[:, c] = gamma**2 / np.einsum("ij,ij->j", phi, M @ phi)
        assert np.allclose(T @ q, r, atol=1e-12)
    for st in parts:
        st.destroy()
    return {
        "scene": str(scene),
        "sets": sets,
        "free_dofs": int(n_q),
        "frequencies_Hz": f.tolist(),
        "effective_mass_fraction": (eff / np.asarray(total)[None, :]).tolist(),
        "eigensolve_s": time.perf_counter() - t0,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?", default=str(ROOT / "demos" / "frame_crane_solid.toml"))
    ap.add_argument("--n", type=int, default=6)
    ap.add_argument("--set", action="append", default=[], dest="sets")
    args = ap.parse_args()
    res = mixed_frequencies(Path(args.scene), args.sets, args.n)
    lines = [
        "# First natural frequencies of a mixed model",
        "",
        f"Command: `.venv/bin/python benchmarks/mixed_modes.py {args.scene} --n {args.n}`",
        "",
        f"{res['free_dofs']} free DOFs after the joints' elimination.",
        "",
        "| mode | f (Hz) | m_eff x | m_eff y | m_eff z |",
        "|---|---|---|---|---|",
    ]
    for k, (fk, e) in enumerate(
        zip(res["frequencies_Hz"], res["effective_mass_fraction"], strict=True), start=1
    ):
        lines.append(f"| {k} | {fk:.3f} | {e[0]:.1%} | {e[1]:.1%} | {e[2]:.1%} |")
    text = "\n".join(lines) + "\n"
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "mixed_modes.md").write_text(text, encoding="utf-8")
    (OUT / "mixed_modes.json").write_text(json.dumps(res, indent=2) + "\n", encoding="utf-8")
    print(text)


if __name__ == "__main__":
    main()
