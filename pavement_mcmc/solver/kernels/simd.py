"""Explicit SIMD vectors of float64 for the numba kernels (LLVM ``<n x double>``, n = 8, 16, 32).

Internal module. numba vectorises an inner loop over sets, but every such loop re-reads from
memory what the previous row just computed, and pays its set-up (alias checks, remainder) once per
row. A vector value (numba type :func:`vec_type`) lives in registers across the node loop instead:
``vload`` / ``vstore`` move ``n`` consecutive doubles of a row of a C-contiguous 2-D array
(``a[i, j : j+n]``, unchecked: the caller pads the sets to a multiple of ``W``), ``vsplat``
broadcasts a scalar; the width comes from a literal or from a vector passed as ``like``, so one
function body serves every width. ``vadd``, ``vsub``, ``vmul``, ``vfma`` (``a b + c``, one
rounding) do the arithmetic in the order written, never reassociated: write the fused
multiply-adds that the scalar loops get under ``fastmath={"contract"}`` as ``vfma`` and a kernel
rounds exactly as they do (a ``vmul`` feeding a ``vadd`` inside a caller compiled with
``contract`` may be fused too). ``n = 8`` is one AVX-512 register (two AVX2 ones); LLVM splits
wider vectors into independent registers, which hides the latency of the node recursions.
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, models, register_model

W = 8  # doubles in the narrowest vector (one AVX-512 register): sets are padded to a multiple


class F64xN(types.Type):
    """numba type of a vector of ``count`` float64 (:func:`vec_type`)."""

    def __init__(self, count: int):
        self.count = count
        super().__init__(name=f"f64x{count}")


@register_model(F64xN)
class _Model(models.PrimitiveModel):
    def __init__(self, dmm, fe_type):
        super().__init__(dmm, fe_type, ir.VectorType(ir.DoubleType(), fe_type.count))


_TYPES: dict[int, F64xN] = {}


def vec_type(count: int) -> F64xN:
    """The (one) numba type of ``count``-double vectors."""
    return _TYPES.setdefault(count, F64xN(count))


def _ll(ty: F64xN):
    return ir.VectorType(ir.DoubleType(), ty.count)


def _width(like) -> int | None:
    """Vector width given as an integer literal (8, 16 or 32) or by a vector of that width; None
    for anything else (numba then retries the call with the literal value)."""
    if isinstance(like, F64xN):
        return like.count
    if isinstance(like, types.IntegerLiteral) and like.literal_value in (W, 2 * W, 4 * W):
        return like.literal_value
    return None


def _check_array(arr) -> None:
    ok = isinstance(arr, types.Array) and arr.ndim == 2 and arr.layout == "C"
    if not (ok and arr.dtype == types.float64):
        raise TypeError(f"simd: a C-contiguous 2-D float64 array is needed, got {arr}")


def _row_ptr(context, builder, arr_ty, arr, i, j, vty):
    """Pointer to ``arr[i, j]`` cast to a vector pointer (no bounds check, no wraparound)."""
    ary = context.make_array(arr_ty)(context, builder, arr)
    shape = cgutils.unpack_tuple(builder, ary.shape, 2)
    strides = cgutils.unpack_tuple(builder, ary.strides, 2)
    ptr = cgutils.get_item_pointer2(context, builder, ary.data, shape, strides, "C", [i, j], wraparound=False)
    return builder.bitcast(ptr, _ll(vty).as_pointer())


def _indices(context, builder, sig, args):
    return [context.cast(builder, v, t, types.intp) for v, t in zip(args[1:3], sig.args[1:3])]


@intrinsic
def vload(typingctx, arr, i, j, like):
    """``arr[i, j : j+n]`` as a vector, ``n`` the width of ``like`` (a vector or a literal)."""
    _check_array(arr)
    if _width(like) is None:
        return None
    vty = vec_type(_width(like))

    def codegen(context, builder, sig, args):
        i_, j_ = _indices(context, builder, sig, args)
        return builder.load(_row_ptr(context, builder, sig.args[0], args[0], i_, j_, vty), align=8)

    return vty(arr, i, j, like), codegen


@intrinsic
def vstore(typingctx, arr, i, j, v):
    """``arr[i, j : j+n] = v``."""
    _check_array(arr)
    if not isinstance(v, F64xN):
        raise TypeError(f"simd.vstore: a vector is needed, got {v}")

    def codegen(context, builder, sig, args):
        i_, j_ = _indices(context, builder, sig, args)
        builder.store(args[3], _row_ptr(context, builder, sig.args[0], args[0], i_, j_, v), align=8)
        return context.get_dummy_value()

    return types.none(arr, i, j, v), codegen


@intrinsic
def vsplat(typingctx, x, like):
    """A vector with every lane ``x``, as wide as ``like`` (a vector or a literal)."""
    if not isinstance(x, (types.Float, types.Integer)):
        raise TypeError(f"simd.vsplat: a number is needed, got {x}")
    if _width(like) is None:
        return None
    vty = vec_type(_width(like))

    def codegen(context, builder, sig, args):
        xd = context.cast(builder, args[0], sig.args[0], types.float64)
        ll = _ll(vty)
        v = builder.insert_element(ir.Constant(ll, ir.Undefined), xd, ir.Constant(ir.IntType(32), 0))
        zeros = ir.Constant(ir.VectorType(ir.IntType(32), vty.count), [0] * vty.count)
        return builder.shuffle_vector(v, ir.Constant(ll, ir.Undefined), zeros)

    return vty(x, like), codegen


def _same(name, *vs):
    if not (isinstance(vs[0], F64xN) and all(v == vs[0] for v in vs)):
        raise TypeError(f"simd.{name}: vectors of one width are needed, got {vs}")


def _binary(op: str):
    def impl(typingctx, a, b):
        _same(f"v{op}", a, b)

        def codegen(context, builder, sig, args):
            return getattr(builder, f"f{op}")(*args)

        return a(a, b), codegen

    impl.__name__ = f"v{op}"
    return intrinsic(impl)


vadd = _binary("add")
vsub = _binary("sub")
vmul = _binary("mul")


@intrinsic
def vfma(typingctx, a, b, c):
    """``a b + c`` with one rounding."""
    _same("vfma", a, b, c)

    def codegen(context, builder, sig, args):
        ll = _ll(a)
        fnty = ir.FunctionType(ll, [ll] * 3)
        fn = cgutils.get_or_insert_function(builder.module, fnty, f"llvm.fma.v{a.count}f64")
        return builder.call(fn, args)

    return a(a, b, c), codegen
