# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Value types of the core: a rigid body, its state, and the wrench applied to it.

All vectors are SI (REP-103): metres, seconds, kilograms, radians. The world frame is inertial;
the body frame is attached to the centre of mass. Orientation R maps body to world
(``r_world = R @ r_body``). Every type is immutable and validated once, at construction: a
``ValueError`` names the offending field, and no half-built object is ever returned. A number is
an int or a float (numpy's too), never a bool or a string, and must fit a finite float.
"""

from __future__ import annotations

from dataclasses import dataclass
import enum
import math
import numbers
import reprlib
from typing import Any

import numpy as np

from rb_sim_ros.core import so3

# Tolerances of validation, relative to the largest principal moment.
SYMMETRY_TOLERANCE = 1e-9
TRIANGLE_TOLERANCE = 1e-9
# How far a given rotation matrix may be from SO(3) before it is refused (it is then projected).
ROTATION_TOLERANCE = 1e-6

_SHORT = reprlib.Repr()
_SHORT.maxlevel, _SHORT.maxlist, _SHORT.maxstring, _SHORT.maxlong = 3, 9, 40, 40


def short(value: Any) -> str:
    """A repr of ``value`` for an error message, cut short whatever its size."""
    return _SHORT.repr(value)


def is_number(value: Any) -> bool:
    """True for an int or a float (Python's or numpy's), False for a bool or anything else."""
    return (type(value) is float or type(value) is int
            or (isinstance(value, numbers.Real) and not isinstance(value, bool)))


def _numbers_only(value: Any, depth: int = 2) -> bool:
    """True when ``value`` is a number, a numeric ndarray, or lists/tuples of them (``depth``
    levels at most): no bools or strings hiding in what numpy would convert."""
    if isinstance(value, np.ndarray):
        return value.dtype.kind in 'iuf'
    if isinstance(value, (list, tuple)):
        if depth <= 0:
            return False
        for c in value:
            if type(c) is not float and not _numbers_only(c, depth - 1):
                return False
        return True
    return is_number(value)


def _float(value: Any) -> float:
    """float(value) of a number, inf for an int too large for a float."""
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


def _vector(name: str, value: Any, size: int = 3) -> np.ndarray:
    if not _numbers_only(value):
        raise ValueError(f'{name} must be {size} numbers, got {short(value)}')
    try:
        arr = np.array(value, dtype=float).reshape(size)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f'{name} must be {size} finite numbers, got {short(value)}') from exc
    if not np.all(np.isfinite(arr)):
        raise ValueError(f'{name} must be finite, got {arr.tolist()}')
    arr.flags.writeable = False
    return arr


def _plain3(value: Any) -> tuple[float, float, float] | None:
    """The 3 floats of a tuple or list of 3 finite Python floats or ints (not bools), or of a
    float64 array of shape (3,) with finite entries; None for anything else."""
    if type(value) is np.ndarray:
        if value.shape != (3,) or value.dtype != np.float64:
            return None
        value = value.tolist()
    elif type(value) is not tuple and type(value) is not list or len(value) != 3:
        return None
    for c in value:
        t = type(c)
        if t is float:
            if not math.isfinite(c):
                return None
        elif t is not int or abs(c) > 2 ** 53:
            return None
    return (float(value[0]), float(value[1]), float(value[2]))


def finite_floats(name: str, value: Any, size: int) -> tuple[float, ...]:
    """``value`` as a tuple of ``size`` finite floats; ValueError naming ``name`` otherwise."""
    try:
        items = tuple(value)
    except TypeError:
        raise ValueError(f'{name} must be {size} numbers, got {short(value)}') from None
    if len(items) != size:
        raise ValueError(f'{name} must be {size} numbers, got {len(items)}')
    for c in items:
        if type(c) is not float and not is_number(c):
            raise ValueError(f'{name} must be {size} numbers, got {short(value)}')
    out = tuple(_float(c) for c in items)
    if not all(math.isfinite(c) for c in out):
        raise ValueError(f'{name} must be finite, got {list(out)}')
    return out


def rate(name: str, value: Any) -> float:
    """A finite rate >= 0 (1/s), such as a damping coefficient; ValueError naming ``name``."""
    if not is_number(value):
        raise ValueError(f'{name} must be a number (1/s), got {short(value)}')
    value = _float(value)
    if not math.isfinite(value) or value < 0.0:
        raise ValueError(f'{name} must be finite and >= 0 (1/s), got {value!r}')
    return value


def non_negative(name: str, value: Any) -> float:
    """A finite number >= 0 (an int or a float, not a bool); ValueError naming ``name``."""
    if not is_number(value) or not math.isfinite(_float(value)) or value < 0.0:
        raise ValueError(f'{name} must be a finite number >= 0, got {short(value)}')
    return float(value)


def _matrix(name: str, value: Any) -> np.ndarray:
    if not _numbers_only(value):
        raise ValueError(f'{name} must be a 3x3 matrix of numbers, got {short(value)}')
    try:
        arr = np.array(value, dtype=float).reshape(3, 3)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f'{name} must be a 3x3 matrix of finite numbers, got {short(value)}'
                         ) from exc
    if not np.all(np.isfinite(arr)):
        raise ValueError(f'{name} must be finite, got {arr.tolist()}')
    return arr


def scaled_to_one(vector: Any) -> np.ndarray | None:
    """``vector`` (finite) times the power of two that brings its largest component into
    [0.5, 1), or None for the zero vector. A norm taken afterwards neither overflows nor
    underflows, and the scaling is exact: a unit vector computed from the result has the bits
    of one computed from ``vector`` wherever that does not overflow or underflow (components
    that become subnormal, below 2^-1022 of [0.5, 1), lose low bits)."""
    vector = np.asarray(vector, dtype=float)
    big = float(np.max(np.abs(vector)))
    if big == 0.0:
        return None
    return np.ldexp(vector, -math.frexp(big)[1])


class Frame(enum.Enum):
    """The frame a wrench is expressed in."""

    WORLD = 'world'
    BODY = 'body'

    @classmethod
    def parse(cls, value: 'Frame | str') -> 'Frame':
        """Frame from a Frame or its name ('world' or 'body'); ValueError names the field."""
        if isinstance(value, Frame):
            return value
        try:
            return cls(str(value).lower())
        except ValueError:
            raise ValueError(f"frame must be 'world' or 'body', got {value!r}") from None


@dataclass(frozen=True, eq=False)
class RigidBody:
    """Mass (kg) and inertia tensor (kg m^2) about the centre of mass, in the body frame.

    The inertia need not be diagonal: any symmetric positive definite tensor whose principal
    moments obey the triangle inequality (I1 + I2 >= I3, as every real mass distribution does).
    """

    mass: float
    inertia: np.ndarray

    def __init__(self, mass: float, inertia: Any) -> None:
        if not is_number(mass):
            raise ValueError(f'mass must be a number, got {short(mass)}')
        mass = _float(mass)
        if not math.isfinite(mass) or mass <= 0.0:
            raise ValueError(f'mass must be finite and > 0 kg, got {mass!r}')
        if np.ndim(inertia) == 1 and np.size(inertia) == 3:
            inertia = np.diag(_vector('inertia', inertia))
        inertia = _matrix('inertia', inertia)
        scale = float(np.max(np.abs(inertia)))
        if scale == 0.0:
            raise ValueError('inertia must be positive definite, got the zero matrix')
        if np.max(np.abs(inertia - inertia.T)) > SYMMETRY_TOLERANCE * scale:
            raise ValueError(f'inertia must be symmetric, got {inertia.tolist()}')
        # Symmetrised and checked as S = I 2^-e, scaled exactly by the power of two that
        # brings its largest entry into [0.5, 1): I + I^T cannot overflow near the largest
        # float nor 0.5 I underflow near the smallest, LAPACK (which can fail on entries near
        # the largest float) sees entries near 1, and I = S 2^e has the bits of 0.5 (I + I^T)
        # wherever that neither overflows nor underflows.
        exponent = math.frexp(scale)[1]
        symmetric = np.ldexp(inertia, -exponent)
        symmetric = 0.5 * (symmetric + symmetric.T)
        inertia = np.ldexp(symmetric, exponent)
        scaled = np.linalg.eigvalsh(symmetric)
        with np.errstate(over='ignore'):  # only shown in a message
            moments = np.ldexp(scaled, exponent)
        if scaled[0] <= 0.0:
            raise ValueError(
                f'inertia must be positive definite, principal moments {moments.tolist()}')
        if scaled[0] + scaled[1] < scaled[2] * (1.0 - TRIANGLE_TOLERANCE):
            raise ValueError(
                'inertia principal moments must obey the triangle inequality I1 + I2 >= I3, '
                f'got {moments.tolist()}')
        inertia.flags.writeable = False
        object.__setattr__(self, 'mass', mass)
        object.__setattr__(self, 'inertia', inertia)

    @property
    def principal_moments(self) -> np.ndarray:
        """Principal moments of inertia (kg m^2), ascending."""
        return np.linalg.eigvalsh(self.inertia)

    @property
    def is_isotropic(self) -> bool:
        """True when the inertia is a multiple of the identity (a sphere, a cube)."""
        return bool(np.array_equal(self.inertia, self.inertia[0, 0] * np.eye(3)))

    @property
    def is_diagonal(self) -> bool:
        """True when the body frame is a principal frame (off-diagonal products are zero)."""
        return bool(np.array_equal(self.inertia, np.diag(np.diag(self.inertia))))

    def inertia_world(self, rotation: np.ndarray) -> np.ndarray:
        """World-frame inertia R I_body R^T (kg m^2), Lemma 1 of the report."""
        rotation = np.asarray(rotation, dtype=float)
        return rotation @ self.inertia @ rotation.T

    def __repr__(self) -> str:
        return f'RigidBody(mass={self.mass!r}, inertia={self.inertia.tolist()!r})'


@dataclass(frozen=True, eq=False)
class State:
    """World-frame state of a body at one instant.

    position: centre of mass (m), world frame.
    rotation: 3x3 matrix taking body-frame vectors to the world frame.
    linear_velocity: velocity of the centre of mass (m/s), world frame.
    angular_velocity: omega (rad/s), world frame.
    """

    position: np.ndarray
    rotation: np.ndarray
    linear_velocity: np.ndarray
    angular_velocity: np.ndarray

    def __init__(self, position: Any = (0.0, 0.0, 0.0), rotation: Any = None,
                 linear_velocity: Any = (0.0, 0.0, 0.0),
                 angular_velocity: Any = (0.0, 0.0, 0.0)) -> None:
        position = _vector('position', position)
        rot = _matrix('rotation', np.eye(3) if rotation is None else rotation)
        err = so3.orthonormality_error(rot)
        if err > ROTATION_TOLERANCE:
            raise ValueError(f'rotation must be a rotation matrix (|R^T R - I| = {err:.3g}), '
                             f'got {rot.tolist()}')
        if err > 0.0:
            rot = so3.orthonormalize(rot)
        rot.flags.writeable = False
        object.__setattr__(self, 'position', position)
        object.__setattr__(self, 'rotation', rot)
        object.__setattr__(self, 'linear_velocity',
                           _vector('linear_velocity', linear_velocity))
        object.__setattr__(self, 'angular_velocity',
                           _vector('angular_velocity', angular_velocity))

    @classmethod
    def from_quaternion_xyzw(cls, position: Any = (0.0, 0.0, 0.0),
                             quaternion_xyzw: Any = (0.0, 0.0, 0.0, 1.0),
                             linear_velocity: Any = (0.0, 0.0, 0.0),
                             angular_velocity: Any = (0.0, 0.0, 0.0)) -> 'State':
        """State whose orientation is given as a quaternion (x, y, z, w) of any non-zero
        length; it is normalised (scaled first by a power of two near 1 / its largest
        component, exactly, so that neither 1e200 nor 1e-200 overflows or underflows)."""
        scaled = scaled_to_one(_vector('quaternion_xyzw', quaternion_xyzw, 4))
        if scaled is None:
            raise ValueError('quaternion_xyzw must be non-zero, got [0.0, 0.0, 0.0, 0.0]')
        rot = so3.matrix_from_quaternion_xyzw(scaled)
        return cls(position, rot, linear_velocity, angular_velocity)

    @property
    def quaternion_xyzw(self) -> np.ndarray:
        """Orientation as a unit quaternion (x, y, z, w) with w >= 0."""
        return so3.quaternion_xyzw_from_matrix(self.rotation)

    @property
    def angular_velocity_body(self) -> np.ndarray:
        """omega in the body frame (rad/s): R^T omega."""
        return self.rotation.T @ self.angular_velocity

    def kinetic_energy(self, body: RigidBody) -> float:
        """Translational plus rotational kinetic energy (J)."""
        wb = self.angular_velocity_body
        v = self.linear_velocity
        return float(0.5 * body.mass * v @ v + 0.5 * wb @ body.inertia @ wb)

    def angular_momentum(self, body: RigidBody) -> np.ndarray:
        """Angular momentum about the centre of mass (kg m^2/s), world frame: R I_b R^T omega."""
        return self.rotation @ (body.inertia @ self.angular_velocity_body)

    def __repr__(self) -> str:
        return (f'State(position={self.position.tolist()}, '
                f'quaternion_xyzw={self.quaternion_xyzw.tolist()}, '
                f'linear_velocity={self.linear_velocity.tolist()}, '
                f'angular_velocity={self.angular_velocity.tolist()})')


@dataclass(frozen=True, eq=False)
class Wrench:
    """Force (N) at the centre of mass and torque (N m) about it, in ``frame``.

    A body-frame wrench turns with the body (a thruster); a world-frame one does not (gravity,
    a tether). Both act at the centre of mass.
    """

    force: np.ndarray
    torque: np.ndarray
    frame: Frame
    _key: tuple

    def __init__(self, force: Any = (0.0, 0.0, 0.0), torque: Any = (0.0, 0.0, 0.0),
                 frame: 'Frame | str' = Frame.WORLD) -> None:
        frame = Frame.parse(frame)
        # Three finite Python floats or ints, or a float64 array of 3 (what a controller and
        # the node pass): checked in Python, one array for both; anything else by the
        # general check.
        f3, t3 = _plain3(force), _plain3(torque)
        if f3 is not None and t3 is not None:
            values = f3 + t3
            arr = np.array(values)
            arr.flags.writeable = False  # before the views: they inherit it
            force, torque = arr[:3], arr[3:]
        else:
            force, torque = _vector('force', force), _vector('torque', torque)
            values = (*force.tolist(), *torque.tolist())
        object.__setattr__(self, 'force', force)
        object.__setattr__(self, 'torque', torque)
        object.__setattr__(self, 'frame', frame)
        # Compared once per publish period by the node: a tuple compares in ~100 ns.
        object.__setattr__(self, '_key', (frame, *values))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Wrench):
            return NotImplemented
        return self._key == other._key

    @property
    def components(self) -> tuple:
        """The six floats: force x, y, z, then torque x, y, z."""
        return self._key[1:]

    def __hash__(self) -> int:
        return hash(self._key)

    def __repr__(self) -> str:
        return (f'Wrench(force={self.force.tolist()}, torque={self.torque.tolist()}, '
                f"frame='{self.frame.value}')")


ZERO_WRENCH = Wrench()
