"""A block row of the symmetric stiffness product in 4-wide vector operations, written in LLVM
IR (numba's auto-vectoriser leaves the 3 × 3 block product scalar: 24 scalar multiply-adds a
block where 6 vector ones do).

One off-diagonal block A (r, c > r) of K's upper block triangle adds A u_c to row r's sum and
Aᵀ u_r to row c. With A stored row by row, each row padded to 4 values (a_i0, a_i1, a_i2, 0):

    acc_i  += (a_i0, a_i1, a_i2, 0) ⊙ (u_c0, u_c1, u_c2, ·)            i = 0, 1, 2
    ku_c   += (a_00, a_01, a_02, 0) r_0 + (a_10, a_11, a_12, 0) r_1 + (a_20, …) r_2

and row r's three sums are the acc_i's lanes added once the row's blocks are done. The u_c and
ku_c vectors are read and written through a 3-lane mask (the fourth value, the next node's,
is neither read nor written). Multiply-adds are ``llvm.fmuladd``: fused where the target has
FMA, a multiply and an add where it does not.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, cast

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = ["upper_row3"]

#: Values stored per off-diagonal block: three rows of A, each padded to 4.
BLOCK = 12


@intrinsic
def _upper_row3(
    typingctx: Any,
    j0: Any,
    j1: Any,
    idx: Any,
    dat: Any,
    u: Any,
    ku: Any,
    r0: Any,
    r1: Any,
    r2: Any,
) -> Any:
    """``(s0, s1, s2) = upper_row3(j0, j1, idx, dat, u, ku, r0, r1, r2)``: over the blocks
    j0 ≤ j < j1 (block column ``idx[j]``, values ``dat[12 j : 12 j + 12]``), returns Σ_j A_j
    u_c(j) and adds A_jᵀ (r0, r1, r2) to ``ku`` at c(j). No bounds checks: the caller's
    arrays are the zone's own (crane_fem.kernels.zone.upper_blocks)."""
    sig = types.UniTuple(types.float64, 3)(j0, j1, idx, dat, u, ku, r0, r1, r2)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        j0v, j1v, idxv, datv, uv, kuv, r0v, r1v, r2v = args
        i32, i64, f64 = ir.IntType(32), ir.IntType(64), ir.DoubleType()
        v4 = ir.VectorType(f64, 4)
        m4 = ir.VectorType(ir.IntType(1), 4)
        p4 = v4.as_pointer()
        a = signature.args
        idx_p = context.make_array(a[2])(context, builder, idxv).data
        dat_p = context.make_array(a[3])(context, builder, datv).data
        u_p = context.make_array(a[4])(context, builder, uv).data
        ku_p = context.make_array(a[5])(context, builder, kuv).data
        mod = builder.module
        fmuladd = cgutils.get_or_insert_function(
            mod, ir.FunctionType(v4, [v4, v4, v4]), "llvm.fmuladd.v4f64"
        )
        mload = cgutils.get_or_insert_function(
            mod, ir.FunctionType(v4, [p4, i32, m4, v4]), "llvm.masked.load.v4f64.p0"
        )
        mstore = cgutils.get_or_insert_function(
            mod, ir.FunctionType(ir.VoidType(), [v4, p4, i32, m4]), "llvm.masked.store.v4f64.p0"
        )
        zero = ir.Constant(v4, [0.0] * 4)
        mask = ir.Constant(m4, [1, 1, 1, 0])
        align = ir.Constant(i32, 8)

        def splat(x: Any) -> Any:
            v = builder.insert_element(ir.Constant(v4, ir.Undefined), x, ir.Constant(i32, 0))
            return builder.shuffle_vector(
                v, ir.Constant(v4, ir.Undefined), ir.Constant(ir.VectorType(i32, 4), [0] * 4)
            )

        rr = (splat(r0v), splat(r1v), splat(r2v))
        acc = [cgutils.alloca_once_value(builder, zero) for _ in range(3)]
        with cgutils.for_range_slice(builder, j0v, j1v, ir.Constant(i64, 1), inc=True) as (jj, _):
            col = builder.sext(builder.load(builder.gep(idx_p, [jj], inbounds=True)), i64)
            c = builder.mul(col, ir.Constant(i64, 3))
            up = builder.bitcast(builder.gep(u_p, [c], inbounds=True), p4)
            x = builder.call(mload, [up, align, mask, zero])
            b = builder.mul(jj, ir.Constant(i64, BLOCK))
            rows = []
            for k in range(3):
                at = builder.gep(dat_p, [builder.add(b, ir.Constant(i64, 4 * k))], inbounds=True)
                row = builder.load(builder.bitcast(at, p4))
                row.align = 8
                rows.append(row)
            for ak, row in zip(acc, rows, strict=True):
                builder.store(builder.call(fmuladd, [row, x, builder.load(ak)]), ak)
            kp = builder.bitcast(builder.gep(ku_p, [c], inbounds=True), p4)
            t = builder.call(
                fmuladd, [rows[0], rr[0], builder.call(mload, [kp, align, mask, zero])]
            )
            t = builder.call(fmuladd, [rows[1], rr[1], t])
            t = builder.call(fmuladd, [rows[2], rr[2], t])
            builder.call(mstore, [t, kp, align, mask])
        sums = []
        for ak in acc:
            v = builder.load(ak)
            e = [builder.extract_element(v, ir.Constant(i32, k)) for k in range(3)]
            sums.append(builder.fadd(builder.fadd(e[0], e[1]), e[2]))
        return context.make_tuple(builder, signature.return_type, sums)

    return sig, codegen


#: :func:`_upper_row3` as its callers see it (an intrinsic's Python signature starts with the
#: typing context).
upper_row3 = cast(Callable[..., tuple[float, float, float]], _upper_row3)
