"""Explicit SIMD vectors of ``W`` float64 for the numba kernels (LLVM ``<W x double>``).

Internal module. numba vectorises an inner loop over sets, but every such loop re-reads from
memory what the previous row just computed, and pays its set-up (alias checks, remainder) once per
row. A value of type :data:`f64xW` lives in registers across the node loop instead: ``vload`` /
``vstore`` move ``W`` consecutive doubles of a row of a C-contiguous 2-D array (``a[i, j : j+W]``,
unchecked: the caller pads the sets to a multiple of ``W``), ``vsplat`` broadcasts a scalar, and
``vadd``, ``vsub``, ``vmul``, ``vfma`` (``a b + c``, one rounding) do the arithmetic in the
order written, never reassociated: write the fused multiply-adds that the scalar loops get under
``fastmath={"contract"}`` as ``vfma`` and a kernel rounds exactly as they do (a ``vmul`` feeding a
``vadd`` inside a caller compiled with ``contract`` may be fused too). ``W = 8`` is one AVX-512
register (two AVX2 ones).
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, models, register_model

W = 8  # doubles per vector


class F64xW(types.Type):
    """numba type of a vector of ``W`` float64."""

    def __init__(self):
        super().__init__(name=f"f64x{W}")


f64xW = F64xW()
_LL = ir.VectorType(ir.DoubleType(), W)


@register_model(F64xW)
class _Model(models.PrimitiveModel):
    def __init__(self, dmm, fe_type):
        super().__init__(dmm, fe_type, _LL)


def _check_array(arr) -> None:
    ok = isinstance(arr, types.Array) and arr.ndim == 2 and arr.layout == "C"
    if not (ok and arr.dtype == types.float64):
        raise TypeError(f"simd: a C-contiguous 2-D float64 array is needed, got {arr}")


def _row_ptr(context, builder, arr_ty, arr, i, j):
    """Pointer to ``arr[i, j]`` cast to a vector pointer (no bounds check, no wraparound)."""
    ary = context.make_array(arr_ty)(context, builder, arr)
    shape = cgutils.unpack_tuple(builder, ary.shape, 2)
    strides = cgutils.unpack_tuple(builder, ary.strides, 2)
    ptr = cgutils.get_item_pointer2(context, builder, ary.data, shape, strides, "C", [i, j], wraparound=False)
    return builder.bitcast(ptr, _LL.as_pointer())


@intrinsic
def vload(typingctx, arr, i, j):
    """``arr[i, j : j+W]`` as a vector."""
    _check_array(arr)

    def codegen(context, builder, sig, args):
        i_, j_ = (context.cast(builder, v, t, types.intp) for v, t in zip(args[1:], sig.args[1:]))
        return builder.load(_row_ptr(context, builder, sig.args[0], args[0], i_, j_), align=8)

    return f64xW(arr, i, j), codegen


@intrinsic
def vstore(typingctx, arr, i, j, v):
    """``arr[i, j : j+W] = v``."""
    _check_array(arr)
    if v is not f64xW:
        raise TypeError(f"simd.vstore: a {f64xW} value is needed, got {v}")

    def codegen(context, builder, sig, args):
        i_, j_ = (context.cast(builder, x, t, types.intp) for x, t in zip(args[1:3], sig.args[1:3]))
        builder.store(args[3], _row_ptr(context, builder, sig.args[0], args[0], i_, j_), align=8)
        return context.get_dummy_value()

    return types.none(arr, i, j, v), codegen


@intrinsic
def vsplat(typingctx, x):
    """A vector with every lane ``x``."""
    if not isinstance(x, (types.Float, types.Integer)):
        raise TypeError(f"simd.vsplat: a number is needed, got {x}")

    def codegen(context, builder, sig, args):
        xd = context.cast(builder, args[0], sig.args[0], types.float64)
        v = builder.insert_element(ir.Constant(_LL, ir.Undefined), xd, ir.Constant(ir.IntType(32), 0))
        zeros = ir.Constant(ir.VectorType(ir.IntType(32), W), [0] * W)
        return builder.shuffle_vector(v, ir.Constant(_LL, ir.Undefined), zeros)

    return f64xW(x), codegen


def _binary(op: str):
    def impl(typingctx, a, b):
        if a is not f64xW or b is not f64xW:
            raise TypeError(f"simd.v{op}: two {f64xW} values are needed, got {a}, {b}")

        def codegen(context, builder, sig, args):
            return getattr(builder, f"f{op}")(*args)

        return f64xW(a, b), codegen

    impl.__name__ = f"v{op}"
    return intrinsic(impl)


vadd = _binary("add")
vsub = _binary("sub")
vmul = _binary("mul")


@intrinsic
def vfma(typingctx, a, b, c):
    """``a b + c`` with one rounding."""
    if not (a is f64xW and b is f64xW and c is f64xW):
        raise TypeError(f"simd.vfma: three {f64xW} values are needed, got {a}, {b}, {c}")

    def codegen(context, builder, sig, args):
        fnty = ir.FunctionType(_LL, [_LL] * 3)
        fn = cgutils.get_or_insert_function(builder.module, fnty, f"llvm.fma.v{W}f64")
        return builder.call(fn, args)

    return f64xW(a, b, c), codegen
