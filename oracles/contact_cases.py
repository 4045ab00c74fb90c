# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The collision scenarios of test/contact/test_collisions.py, which bench.collision_cases
runs again to measure what the tests bound (docs/collisions.md, "Measured"), and the solver
cases of test/contact/test_rolling_resistance.py and test/support/solver_fingerprint.py: the
same bodies, seeds and settings wherever they run, with the closed forms they are checked
against (momenta, the effective mass of a contact, its normal velocity and slip).

Worlds are at dt = 1 ms unless said, gravity ``G`` (m/s^2); ``GROUND`` is the plane z = 0.
"""

import numpy as np

from rb_sim_ros.contact import contact_solver as cs
from rb_sim_ros.contact.collision_shapes import Box, Capsule, Plane, Sphere
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.core import so3
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.simulation import BodySpec

G = (0.0, 0.0, -9.81)
GROUND = (Plane(),)


# -- the solver on single impacts --------------------------------------------------------------
def random_inertia(rng, scale=1.0):
    moments = np.sort(rng.uniform(0.5, 1.0, 3)) * scale
    q = so3.exp(rng.normal(size=3))
    return q @ np.diag(moments) @ q.T


def impact(rng, restitution, friction=0.0, static_b=False):
    """Two free bodies (full inertia tensors, turned, spinning) meeting at an off-centre point;
    returns (bodies, contacts, masses, body-frame inertias, rotations, settings)."""
    masses = rng.uniform(0.5, 3.0, 2)
    inertias = [random_inertia(rng), random_inertia(rng, 2.0)]
    rotations = [so3.exp(rng.normal(size=3)) for _ in range(2)]
    position = np.array([[0.0, 0.0, 0.0], [0.3, -0.2, 1.1]]) + rng.normal(size=(2, 3)) * 0.1
    v, w = rng.normal(size=(2, 3)), rng.normal(size=(2, 3)) * 3.0
    point = 0.5 * (position[0] + position[1]) + rng.normal(size=3) * 0.2
    normal = position[1] - position[0] + rng.normal(size=3) * 0.3
    normal /= np.linalg.norm(normal)
    inv_mass = 1.0 / masses
    inv_inertia = np.array([r @ np.linalg.inv(i) @ r.T for r, i in zip(rotations, inertias)])
    if static_b:
        inv_mass[1] = 0.0
        inv_inertia[1] = 0.0
        v[1] = w[1] = 0.0
    bodies = cs.Bodies(position, v, w, inv_mass, inv_inertia)
    contacts = cs.ContactArrays(np.array([0]), np.array([1]), point[None], normal[None],
                                np.array([0.0]))
    if normal_velocity(contacts, bodies, v, w) > 0.0:    # make them approach
        bodies.velocity, bodies.angular_velocity = -v, -w
    settings = cs.SolverSettings(restitution=restitution, friction=friction,
                                 bounce_threshold=0.0, position_iterations=0,
                                 velocity_iterations=200 if friction else 10, tolerance=0.0)
    return bodies, contacts, masses, inertias, rotations, settings


def momenta(bodies, v, w, masses, inertias, rotations, origin=np.array([0.7, -1.3, 2.1])):
    p = masses[0] * v[0] + masses[1] * v[1]
    angular = sum(masses[k] * np.cross(bodies.position[k] - origin, v[k])
                  + rotations[k] @ inertias[k] @ rotations[k].T @ w[k] for k in range(2))
    energy = sum(0.5 * masses[k] * v[k] @ v[k]
                 + 0.5 * w[k] @ rotations[k] @ inertias[k] @ rotations[k].T @ w[k]
                 for k in range(2))
    return p, angular, energy


def normal_velocity(contacts, bodies, v, w):
    n, p = contacts.normal[0], contacts.point[0]
    ra, rb = p - bodies.position[0], p - bodies.position[1]
    return float(n @ (v[1] + np.cross(w[1], rb) - v[0] - np.cross(w[0], ra)))


def effective_mass(contacts, bodies):
    """K = 1/m_a + 1/m_b + n . ((I_a^-1 (r_a x n)) x r_a + (I_b^-1 (r_b x n)) x r_b)."""
    n, p = contacts.normal[0], contacts.point[0]
    ra, rb = p - bodies.position[0], p - bodies.position[1]
    ia, ib = bodies.inverse_inertia
    return float(bodies.inverse_mass.sum()
                 + n @ (np.cross(ia @ np.cross(ra, n), ra) + np.cross(ib @ np.cross(rb, n), rb)))


def contact_slip(bodies, contacts, result):
    """(normal, tangential slip velocity after the solve, tangent impulse) of contact 0
    between bodies 0 and 1."""
    v1, w1 = result.velocity, result.angular_velocity
    n, p = contacts.normal[0], contacts.point[0]
    ra, rb = p - bodies.position[0], p - bodies.position[1]
    rel = v1[1] + np.cross(w1[1], rb) - v1[0] - np.cross(w1[0], ra)
    return n, rel - (rel @ n) * n, result.tangent_impulse[0]


def random_contact_set(rng, count=120, bodies_count=31, spin=1.0):
    """``count`` random contacts among ``bodies_count`` - 1 free bodies (full inertia tensors)
    and a static one, the last (a plane, say): (Bodies, ContactArrays)."""
    inv_mass = np.append(rng.uniform(0.3, 2.0, bodies_count - 1), 0.0)
    inv_inertia = np.array([np.linalg.inv(random_inertia(rng)) for _ in range(bodies_count)])
    inv_inertia[-1] = 0.0
    bodies = cs.Bodies(rng.normal(size=(bodies_count, 3)), rng.normal(size=(bodies_count, 3)),
                       rng.normal(size=(bodies_count, 3)) * spin, inv_mass, inv_inertia)
    bodies.velocity[-1] = bodies.angular_velocity[-1] = 0.0
    a = rng.integers(0, bodies_count - 1, count)
    b = (a + rng.integers(1, bodies_count, count)) % bodies_count
    normal = rng.normal(size=(count, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    contacts = cs.ContactArrays(a, b, rng.normal(size=(count, 3)), normal,
                                rng.uniform(-0.01, 0.01, count))
    return bodies, contacts


# -- worlds ------------------------------------------------------------------------------------
def ball(name='ball', radius=0.1, position=(0.0, 0.0, 1.0), velocity=(0.0, 0.0, 0.0), mass=1.0):
    return BodySpec(name, mass, (0.4 * mass * radius ** 2,) * 3, initial_position=position,
                    initial_linear_velocity=velocity, colliders=(Sphere(radius),))


def cube(name, size, position, mass=1.0, **kwargs):
    sx, sy, sz = size
    inertia = (mass / 12 * (sy * sy + sz * sz), mass / 12 * (sx * sx + sz * sz),
               mass / 12 * (sx * sx + sy * sy))
    return BodySpec(name, mass, inertia, initial_position=position, colliders=(Box(size),),
                    **kwargs)


def apexes(world, name, steps):
    """Heights of the tops after each bounce (the largest z between two steps with an
    impulse; the fall before the first one is not a top)."""
    out, best, bounced = [], None, False
    for _ in range(steps):
        world.step(1)
        z = float(world.state(name).position[2])
        if any(c.normal_impulse > 0 for c in world.last_contacts()):
            if bounced and best is not None:
                out.append(best)
            best, bounced = None, True
        else:
            best = z if best is None else max(best, z)
    return out


def thin_wall_run(speed, speculative, phase, r=0.05, width=0.01, dt=1e-3):
    start = -(0.3 + r + width / 2 + (1.0 + phase) * speed * dt)
    wall = BodySpec('wall', static=True, colliders=(Box((width, 1.0, 1.0)),))
    world = collision_world([ball(radius=r, position=(start, 0.0, 0.0), velocity=(speed, 0, 0)),
                            wall], dt,
                            contact=ContactSettings(restitution=0.5, speculative=speculative))
    world.step(int(-2 * start / (speed * dt)) + 3)
    return float(world.state('ball').position[0])


def mixed_scene():
    walls = (Plane((0, 0, 1), 0.0), Plane((1, 0, 0), -1.0), Plane((-1, 0, 0), -1.0),
             Plane((0, 1, 0), -1.0), Plane((0, -1, 0), -1.0))
    capsule_inertia = (0.02, 0.02, 0.005)
    bodies = [ball('ball0', 0.1, (0.3, 0.2, 0.5), (1.0, -0.5, 0.0)),
              ball('ball1', 0.15, (-0.2, 0.1, 0.9), (-2.0, 0.0, 0.0)),
              cube('crate', (0.3, 0.2, 0.2), (0.0, -0.3, 0.3), initial_angular_velocity=(1, 2, 0)),
              BodySpec('rod', 1.0, capsule_inertia, initial_position=(0.1, 0.4, 1.3),
                       initial_orientation_xyzw=(0.3, 0.0, 0.0, 1.0),
                       colliders=(Capsule(0.05, 0.4),)),
              BodySpec('dumbbell', 2.0, (0.05, 0.05, 0.01), initial_position=(-0.4, -0.4, 1.0),
                       colliders=(Sphere(0.08, position=(0.0, 0.0, 0.15)),
                                  Sphere(0.08, position=(0.0, 0.0, -0.15)),
                                  Capsule(0.02, 0.3))),
              BodySpec('pillar', static=True, initial_position=(0.6, -0.6, 0.25),
                       colliders=(Box((0.2, 0.2, 0.5)),))]
    return collision_world(bodies, 1e-3, G, planes=walls,
                           contact=ContactSettings(restitution=0.3, friction=0.5))


def mechanical_energy(world):
    """Kinetic and potential energy (g = 9.81 along -z) of a world's moving bodies (J)."""
    return sum(world.state(name).kinetic_energy(s.body)
               + s.body.mass * 9.81 * world.state(name).position[2]
               for name, s in world.steppers.items())
