"""An explicit vector of 4 doubles for numba kernels: packed AVX arithmetic without fast-math.

numba leaves LLVM's SLP vectoriser off and cannot tell LLVM that arrays do not alias,
so loops over 4 lanes stay scalar (docs/engine.md). A value of type `Vec4` is one
LLVM ``<4 x double>``: every operation below is one IEEE operation per lane (``fadd``,
``fsub``, ``fmul``, ``fdiv``, ``llvm.sqrt``, ``llvm.floor``, ``fcmp``, ``select`` on
the vector type, no fast-math flags), so lane k of a result has the same bits as the
scalar operation on lane k's operands. Nothing here fuses a multiply and an add.

In a kernel (numba-compiled code)::

    v = load(a, (i, l0))            # a[i, l0:l0 + 4], the lane axis contiguous (C order)
    w = v * 2.0 + splat(x)          # float operands are broadcast
    m = w > 0.0                     # a Mask4
    store(out, (i, l0), select(m, w, 0.0))
    lane(w, 2)                      # one lane as a float

`ops.select(c, a, b)` and `ops.floor(x)` take floats (and bools) or vectors here, and
are plain Python functions outside numba, so one formula (e.g. `trig.sincos`) serves
floats, vectors and the interpreter. The types and their lowering are defined at module level,
so kernels using them can be cached (``cache=True``); a cached kernel needs this
module imported, which the kernels do.
"""

from __future__ import annotations

import math
import operator

from llvmlite import ir
from numba.core import cgutils, types
from numba.core.imputils import lower_builtin
from numba.core.typing.templates import AbstractTemplate, infer_global, signature
from numba.extending import intrinsic, models, overload, register_model

from .ops import floor, select

WIDTH = 4

_D = ir.DoubleType()
_V = ir.VectorType(_D, WIDTH)
_M = ir.VectorType(ir.IntType(1), WIDTH)


class Vec4Type(types.Type):
    def __init__(self):
        super().__init__(name="Vec4")


class Mask4Type(types.Type):
    def __init__(self):
        super().__init__(name="Mask4")


vec4_t = Vec4Type()
mask4_t = Mask4Type()


@register_model(Vec4Type)
class _Vec4Model(models.PrimitiveModel):
    def __init__(self, dmm, fe_type):
        super().__init__(dmm, fe_type, _V)


@register_model(Mask4Type)
class _Mask4Model(models.PrimitiveModel):
    def __init__(self, dmm, fe_type):
        super().__init__(dmm, fe_type, _M)


def _is_scalar(t) -> bool:
    return isinstance(t, (types.Float, types.Integer))


def _splat_value(builder, d):
    v = ir.Constant(_V, ir.Undefined)
    for k in range(WIDTH):
        v = builder.insert_element(v, d, ir.Constant(ir.IntType(32), k))
    return v


def _as_vec(context, builder, ty, val):
    """A Vec4 operand as it is, a float or integer operand broadcast to 4 lanes."""
    if isinstance(ty, Vec4Type):
        return val
    return _splat_value(builder, context.cast(builder, val, ty, types.float64))


def _intrinsic_fn(builder, name):
    fnty = ir.FunctionType(_V, [_V])
    return cgutils.get_or_insert_function(builder.module, fnty, f"llvm.{name}.v4f64")


# ---- arithmetic: + - * / between vectors and vectors or scalars ----

_ARITH = {operator.add: "fadd", operator.sub: "fsub", operator.mul: "fmul",
          operator.truediv: "fdiv", operator.iadd: "fadd", operator.isub: "fsub",
          operator.imul: "fmul", operator.itruediv: "fdiv"}


def _vec_operands(args) -> bool:
    if len(args) != 2:
        return False
    a, b = args
    return ((isinstance(a, Vec4Type) and (isinstance(b, Vec4Type) or _is_scalar(b)))
            or (_is_scalar(a) and isinstance(b, Vec4Type)))


def _register_binary(op, result, emit):
    """op(a, b) for a Vec4 and a Vec4, float or integer (either side), giving ``result``:
    emit(builder, a, b) on the two operands as vectors."""
    class _Template(AbstractTemplate):
        def generic(self, args, kws):
            if not kws and _vec_operands(args):
                return signature(result, *args)

    infer_global(op)(_Template)

    def impl(context, builder, sig, args):
        a = _as_vec(context, builder, sig.args[0], args[0])
        b = _as_vec(context, builder, sig.args[1], args[1])
        return emit(builder, a, b)

    for types_ in ((Vec4Type, Vec4Type), (Vec4Type, types.Number), (types.Number, Vec4Type)):
        lower_builtin(op, *types_)(impl)


for _op, _instr in _ARITH.items():
    _register_binary(_op, vec4_t, lambda builder, a, b, _i=_instr: getattr(builder, _i)(a, b))


def _register_unary(op, operand, result, instr):
    """-v of a Vec4 (fneg), ~m of a Mask4 (not)."""
    class _Template(AbstractTemplate):
        def generic(self, args, kws):
            if len(args) == 1 and isinstance(args[0], operand):
                return signature(result, result)

    infer_global(op)(_Template)

    @lower_builtin(op, operand)
    def impl(context, builder, sig, args):
        return getattr(builder, instr)(args[0])


_register_unary(operator.neg, Vec4Type, vec4_t, "fneg")


# ---- comparisons (a Mask4) and the operations on masks ----

_COMPARE = {operator.lt: ("<", True), operator.le: ("<=", True), operator.gt: (">", True),
            operator.ge: (">=", True), operator.eq: ("==", True), operator.ne: ("!=", False)}


for _op, (_sym, _ordered) in _COMPARE.items():
    # as Python compares floats: ordered, except != (true when either is nan)
    _register_binary(_op, mask4_t, lambda builder, a, b, _s=_sym, _o=_ordered: (
        builder.fcmp_ordered(_s, a, b) if _o else builder.fcmp_unordered(_s, a, b)))


def _register_mask_op(op, instr):
    class _Template(AbstractTemplate):
        def generic(self, args, kws):
            if len(args) == 2 and all(isinstance(a, Mask4Type) for a in args):
                return signature(mask4_t, mask4_t, mask4_t)

    infer_global(op)(_Template)

    @lower_builtin(op, Mask4Type, Mask4Type)
    def impl(context, builder, sig, args):
        return getattr(builder, instr)(args[0], args[1])


_register_mask_op(operator.and_, "and_")
_register_mask_op(operator.or_, "or_")

_register_unary(operator.invert, Mask4Type, mask4_t, "not_")


# ---- construction, lanes, memory ----

@intrinsic
def splat(typingctx, x):
    """A Vec4 with every lane x."""
    if not _is_scalar(x):
        return None

    def codegen(context, builder, sig, args):
        return _as_vec(context, builder, sig.args[0], args[0])

    return signature(vec4_t, x), codegen


@intrinsic
def vec4(typingctx, a, b, c, d):
    """The Vec4 (a, b, c, d)."""
    if not all(_is_scalar(t) for t in (a, b, c, d)):
        return None

    def codegen(context, builder, sig, args):
        v = ir.Constant(_V, ir.Undefined)
        for k, (ty, val) in enumerate(zip(sig.args, args)):
            d_ = context.cast(builder, val, ty, types.float64)
            v = builder.insert_element(v, d_, ir.Constant(ir.IntType(32), k))
        return v

    return signature(vec4_t, a, b, c, d), codegen


@intrinsic
def lane(typingctx, v, k):
    """Lane k of a Vec4 (a float), or of a Mask4 (a bool)."""
    if not isinstance(k, types.Integer):
        return None
    if isinstance(v, Vec4Type):
        out = types.float64
    elif isinstance(v, Mask4Type):
        out = types.boolean
    else:
        return None

    def codegen(context, builder, sig, args):
        return builder.extract_element(args[0], args[1])

    return signature(out, v, k), codegen


def _element_pointer(context, builder, aryty, ary, idxty, idx):
    array = context.make_array(aryty)(context, builder, ary)
    if isinstance(idxty, types.BaseTuple):
        indices = cgutils.unpack_tuple(builder, idx, len(idxty))
        kinds = idxty.types
    else:
        indices = [idx]
        kinds = [idxty]
    indices = [context.cast(builder, i, t, types.intp) for i, t in zip(indices, kinds)]
    return cgutils.get_item_pointer(context, builder, aryty, array, indices, wraparound=False)


def _check_index(arr, idx) -> bool:
    if not (isinstance(arr, types.Array) and arr.dtype == types.float64 and arr.layout == "C"):
        return False
    if isinstance(idx, types.Integer):
        return arr.ndim == 1
    return (isinstance(idx, types.BaseTuple) and len(idx) == arr.ndim
            and all(isinstance(t, types.Integer) for t in idx.types))


@intrinsic
def load(typingctx, arr, idx):
    """The Vec4 arr[idx], arr[idx + 1], ... along the last axis (a C-contiguous float64
    array; idx an integer for 1-D, a tuple of indices otherwise). No bounds check."""
    if not _check_index(arr, idx):
        return None

    def codegen(context, builder, sig, args):
        ptr = _element_pointer(context, builder, sig.args[0], args[0], sig.args[1], args[1])
        return builder.load(builder.bitcast(ptr, _V.as_pointer()), align=8, typ=_V)

    return signature(vec4_t, arr, idx), codegen


@intrinsic
def store(typingctx, arr, idx, v):
    """Write the Vec4 v to arr[idx], arr[idx + 1], ... along the last axis (see `load`)."""
    if not (_check_index(arr, idx) and isinstance(v, Vec4Type)):
        return None

    def codegen(context, builder, sig, args):
        ptr = _element_pointer(context, builder, sig.args[0], args[0], sig.args[1], args[1])
        builder.store(args[2], builder.bitcast(ptr, _V.as_pointer()), align=8)
        return context.get_dummy_value()

    return signature(types.none, arr, idx, v), codegen


# ---- functions on vectors ----

def _unary(name):
    def typer(typingctx, v):
        if not isinstance(v, Vec4Type):
            return None

        def codegen(context, builder, sig, args):
            return builder.call(_intrinsic_fn(builder, name), [args[0]])

        return signature(vec4_t, v), codegen

    return typer


vsqrt = intrinsic(_unary("sqrt"))
vsqrt.__doc__ = "The correctly rounded square root of every lane (llvm.sqrt: vsqrtpd)."
vfloor = intrinsic(_unary("floor"))
vfloor.__doc__ = "floor of every lane (llvm.floor: vroundpd)."
vabs = intrinsic(_unary("fabs"))
vabs.__doc__ = "|x| of every lane (llvm.fabs)."


@intrinsic
def _vselect(typingctx, c, a, b):
    if not isinstance(c, Mask4Type):
        return None
    if not all(isinstance(t, Vec4Type) or _is_scalar(t) for t in (a, b)):
        return None

    def codegen(context, builder, sig, args):
        x = _as_vec(context, builder, sig.args[1], args[1])
        y = _as_vec(context, builder, sig.args[2], args[2])
        return builder.select(args[0], x, y)

    return signature(vec4_t, c, a, b), codegen


@intrinsic
def any_lane(typingctx, m):
    """True when some lane of the Mask4 m is true."""
    if not isinstance(m, Mask4Type):
        return None

    def codegen(context, builder, sig, args):
        bits = builder.bitcast(args[0], ir.IntType(WIDTH))
        return builder.icmp_unsigned("!=", bits, ir.Constant(ir.IntType(WIDTH), 0))

    return signature(types.boolean, m), codegen


def isfinite4(v):
    """A Mask4: the lanes of v that are neither inf nor nan (only in compiled code)."""
    raise NotImplementedError("isfinite4 works in numba-compiled code only")


@overload(isfinite4)
def _isfinite4(v):
    if isinstance(v, Vec4Type):
        return lambda v: vabs(v) < math.inf


# ---- ops.select and ops.floor for floats and vectors alike ----

@overload(select)
def _select_overload(c, a, b):
    if isinstance(c, Mask4Type):
        return lambda c, a, b: _vselect(c, a, b)
    if isinstance(c, types.Boolean) and _is_scalar(a) and _is_scalar(b):
        return lambda c, a, b: _bselect(c, float(a), float(b))


@intrinsic
def _bselect(typingctx, c, a, b):
    if not (isinstance(c, types.Boolean) and a == types.float64 and b == types.float64):
        return None

    def codegen(context, builder, sig, args):
        return builder.select(args[0], args[1], args[2])

    return signature(types.float64, c, a, b), codegen


@intrinsic
def _sfloor(typingctx, x):
    if x != types.float64:
        return None

    def codegen(context, builder, sig, args):
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(_D, [_D]),
                                            "llvm.floor.f64")
        return builder.call(fn, [args[0]])

    return signature(types.float64, x), codegen


@overload(floor)
def _floor_overload(x):
    if isinstance(x, Vec4Type):
        return lambda x: vfloor(x)
    if isinstance(x, types.Float):
        return lambda x: _sfloor(x)


@overload(abs)
def _abs_overload(v):
    if isinstance(v, Vec4Type):
        return lambda v: vabs(v)


@overload(math.sqrt)
def _sqrt_overload(v):
    if isinstance(v, Vec4Type):
        return lambda v: vsqrt(v)
