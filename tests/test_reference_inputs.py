"""twip.reference refuses the inputs the bindings refuse, with their message: it read every
number with float(), so a bool was 0 or 1, a complex its real part (or a TypeError of
float's own wording), and a string "1.5" a number, where the Rust side refuses all three."""
from decimal import Decimal
from fractions import Fraction

import numpy as np
import pytest

import twip
from twip import reference as ref

_P = twip.RobotParams.balanbot()
_REF_P = ref.RobotParams.of(_P)

#: (argument, the reference's call, the bindings' call) with `v` in that argument.
CALLS = {
    "Trapezoid": ("a", lambda v: ref.Trapezoid(v, 0.0, 1.0, 2.0), lambda v: twip.Trapezoid(v, 0.0, 1.0, 2.0)),
    "Gaussian": ("sigma", lambda v: ref.Gaussian(0.0, v), lambda v: twip.Gaussian(0.0, v)),
    "SlopeModel": ("slope", lambda v: ref.SlopeModel(_REF_P, v), lambda v: twip.SlopeModel(_P, v)),
    "Circle": ("radius", lambda v: ref.Circle(v, 1.0), lambda v: twip.Circle(v, 1.0)),
    "Line": ("speed", lambda v: ref.Line(v), lambda v: twip.Line(v)),
    "DcMotor": ("resistance", lambda v: ref.DcMotor(v, 0.01, 43.7, 0.0, 11.1),
                lambda v: twip.DcMotor(v, 0.01, 43.7, 0.0, 11.1)),
}
REFUSED = [True, np.True_, 1 + 0j, np.complex64(1), "1.5"]


@pytest.mark.parametrize("value", REFUSED, ids=repr)
@pytest.mark.parametrize("call", CALLS, ids=str)
def test_the_reference_refuses_what_the_bindings_refuse_in_their_words(call, value):
    arg, reference, core = CALLS[call]
    with pytest.raises(TypeError) as by_ref:
        reference(value)
    with pytest.raises(TypeError) as by_core:
        core(value)
    assert str(by_ref.value).startswith(f"{arg}: ")
    assert str(by_ref.value) == str(by_core.value)


@pytest.mark.parametrize("value", REFUSED, ids=repr)
def test_the_references_parameters_and_lists_refuse_them_too(value):
    with pytest.raises(TypeError, match=r"^m_body: "):
        _REF_P.replace(m_body=value)
    with pytest.raises(TypeError, match=r"^m_body: "):
        ref.RobotParams.from_dict({**_REF_P.to_dict(), "m_body": value})
    with pytest.raises(TypeError, match=r"^legs\[0\]\[1\]: "):
        ref.SpeedSchedule([(1.0, value, 0.0)])
    with pytest.raises(TypeError, match=r"^points\[1\]\[0\]: "):
        ref.Waypoints([(0.0, 0.0), (value, 1.0)], 0.5)


@pytest.mark.parametrize("kind", [int, np.float32, np.int64, Fraction, Decimal, np.array])
def test_the_reference_takes_every_real_number_the_bindings_take(kind):
    assert ref.Trapezoid(kind(-1), 0.0, 1.0, 2.0).a == -1.0
    assert ref.SlopeModel(_REF_P, kind(0)).slope == 0.0
