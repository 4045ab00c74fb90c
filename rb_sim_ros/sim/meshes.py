# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Mesh files as convex hulls: the parts of a mesh file (each connected piece of its
surface, or each object of a file of several: the parts of a convex decomposition), each the
points of one ``Hull`` collider, and the mass properties of the solid they make; or as a
terrain's surface (``mesh_surface``: all its triangles).

A mesh file is untrusted input: ``mesh_parts`` reads one only from under the folders it is
allowed (``roots``: the scene file's folder), of at most MAX_BYTES, of a binary or plain-text
format (STL, OBJ, PLY, OFF, GLB: not the XML ones, DAE and 3MF, whose parsers expand what
they are given), with at most MAX_VERTICES vertices and MAX_PARTS parts, every vertex finite;
anything else is a MeshError naming the file and the reason. trimesh reads them (imported
only when a mesh is read).
"""

from __future__ import annotations

import io
import os
from pathlib import Path
from typing import cast, Sequence

import numpy as np

from rb_sim_ros.contact.colliders import MAX_COLLIDERS
from rb_sim_ros.contact.shapes import hull
from rb_sim_ros.core.rigid_body import short

MAX_BYTES = 64 * 1024 * 1024
MAX_VERTICES = 1_000_000
MAX_PARTS = MAX_COLLIDERS
MAX_NAME = 4096
FORMATS = ('.stl', '.obj', '.ply', '.off', '.glb')
# coacd's concavity threshold (its default: a part's surface within 5% of the mesh's size of
# its hull)
DECOMPOSE_THRESHOLD = 0.05


def _shown(name) -> str:
    """A file name for a one-line message: control characters escaped, cut short."""
    text = name if isinstance(name, str) else repr(name)
    text = text.encode('unicode_escape').decode('ascii')
    return text if len(text) <= 160 else text[:157] + '...'


class MeshError(ValueError):
    """A mesh file that cannot be used; the message names the file and the reason."""


def resolve(name: str, roots: Sequence[Path]) -> Path:
    """The file ``name`` (relative to the first of ``roots``, or absolute), which must lie
    under one of ``roots`` once links are followed."""
    if not isinstance(name, str) or not name or '\0' in name or len(name) > MAX_NAME:
        raise MeshError(f'a mesh file name must be a string of 1 to {MAX_NAME} characters, got '
                        f'{_shown(name)}')
    if not roots:
        raise MeshError(f'{_shown(name)}: a mesh file is read relative to a scene file, and '
                        'there is none here (a body given as text cannot name one)')
    try:
        path = (Path(roots[0]) / name).resolve()
        inside = any(path.is_relative_to(Path(r).resolve()) for r in roots)
        if inside and not path.is_file():
            raise MeshError(f'{_shown(name)}: no such file ({_shown(str(path))})')
        size = os.path.getsize(path) if inside else 0
    except (OSError, RuntimeError) as e:  # a loop of links, a name too long
        raise MeshError(f'{_shown(name)}: cannot be read ({type(e).__name__}: '
                        f'{short(str(e))})') from None
    if not inside:
        raise MeshError(f'{_shown(name)}: outside the folders mesh files are read from '
                        f'({short(", ".join(str(r) for r in roots))})')
    if path.suffix.lower() not in FORMATS:
        raise MeshError(f'{_shown(name)}: not a mesh format read here ({", ".join(FORMATS)}; '
                        'the XML ones are not read)')
    if size > MAX_BYTES:
        raise MeshError(f'{_shown(name)}: {size} bytes, more than MAX_BYTES = {MAX_BYTES}')
    return path


def ros_resource(uri: str, folder: Path | None) -> tuple[str, tuple[Path, ...]]:
    """(name, roots) of a mesh a ROS model names as ROS does: ``package://pkg/path`` under
    the share folder of ``pkg`` (ament's index, or a share/pkg of AMENT_PREFIX_PATH),
    ``file:///path`` or a plain path relative to ``folder`` (the model file's; None for a
    model given as text). The roots allowed are ``folder`` and the share folders of the
    installed ROS packages: nothing else is read."""
    if not isinstance(uri, str) or not uri:
        raise MeshError(f'a mesh filename must be a non-empty string, got {short(uri)}')
    shares = _shares()
    own = (folder,) if folder is not None else ()
    if uri.startswith('package://'):
        package, _, rest = uri[len('package://'):].partition('/')
        share = shares.get(package)
        if share is None or not rest:
            raise MeshError(f"{_shown(uri)}: no ROS package '{_shown(package)}' is installed "
                            'here (none in AMENT_PREFIX_PATH)')
        return rest, (share, *own, *shares.values())
    if uri.startswith('file://'):
        uri = uri[len('file://'):]
    if not own and not os.path.isabs(uri):
        raise MeshError(f'{_shown(uri)}: a relative mesh path needs the model file it is '
                        'relative to (a model given as text can name package:// meshes)')
    return uri, (*own, *shares.values())


def _shares() -> dict[str, Path]:
    """The share folder of each ROS package installed (ament's prefixes)."""
    out: dict[str, Path] = {}
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        index = Path(prefix) / 'share' / 'ament_index' / 'resource_index' / 'packages'
        if prefix and index.is_dir():
            for marker in sorted(index.iterdir()):
                out.setdefault(marker.name, Path(prefix) / 'share' / marker.name)
    return out


def mesh_parts(name: str, roots: Sequence[Path], scale=1.0,
               decompose: bool = False) -> list[np.ndarray]:
    """The points (N, 3) (m, the file's frame times ``scale``: a number or 3) of each part
    of the mesh file ``name``: each object of a file of several, else each connected piece of
    its surface; with ``decompose``, each piece cut into convex parts by coacd (an
    approximate convex decomposition, its seed fixed: the same parts every time). The file's
    bytes alone are read: no file it names (an OBJ's materials, a GLB's buffers)."""
    path = resolve(name, roots)
    scale = _scale(name, scale)
    if not isinstance(decompose, bool):
        raise MeshError(f'{_shown(name)}: decompose must be true or false, got '
                        f'{short(decompose)}')
    try:
        stat = path.stat()
        key = (str(path), stat.st_mtime_ns, stat.st_size, decompose)
        if key not in _READ:
            data = path.read_bytes()[:MAX_BYTES + 1]
            if len(data) > MAX_BYTES:
                raise MeshError(f'{_shown(name)}: more than MAX_BYTES = {MAX_BYTES}')
            while len(_READ) >= CACHED:
                _READ.pop(next(iter(_READ)))
            _READ[key] = _parts(_shown(name), data, path.suffix.lower()[1:], decompose)
        return [part * scale for part in _READ[key]]
    except OSError as e:
        raise MeshError(f'{_shown(name)}: cannot be read ({type(e).__name__})') from None


# The parts of the files read last (a scene of many bodies of one mesh reads it once).
CACHED = 16
_READ: dict[tuple, list[np.ndarray]] = {}


def _file_meshes(trimesh, name: str, data: bytes, kind: str) -> tuple[list, int]:
    """(the triangle meshes of a mesh file's bytes ``data`` of type ``kind``, every object of
    a scene; their vertex count), refused above MAX_VERTICES (a scene's counted before its
    instances are made)."""
    loaded = trimesh.load(io.BytesIO(data), file_type=kind, process=False, resolver=None,
                          skip_materials=True)
    if isinstance(loaded, trimesh.Scene):
        total = sum(len(getattr(loaded.geometry.get(loaded.graph[n][1]), 'vertices', ()))
                    for n in loaded.graph.nodes_geometry)
    else:
        total = len(getattr(loaded, 'vertices', ()))
    if total > MAX_VERTICES:
        raise MeshError(f'{name}: {total} vertices, more than MAX_VERTICES = '
                        f'{MAX_VERTICES} (decimate it first)')
    if isinstance(loaded, trimesh.Scene):
        return [g for g in loaded.dump() if isinstance(g, trimesh.Trimesh)], total
    return ([loaded] if isinstance(loaded, trimesh.Trimesh) else []), total


def _parts(name: str, data: bytes, kind: str, decompose: bool) -> list[np.ndarray]:
    try:
        import trimesh
    except ImportError:
        raise MeshError(f'{name}: reading mesh files needs trimesh (pip install trimesh, or '
                        'rosdep: python3-trimesh)') from None
    try:
        meshes, total = _file_meshes(trimesh, name, data, kind)
        if not meshes or total == 0 or not any(len(m.faces) for m in meshes):
            raise MeshError(f'{name}: holds no triangles')
        parts: list[np.ndarray] = []
        for mesh in meshes:
            vertices = np.asarray(mesh.vertices, dtype=np.float64)
            faces = np.asarray(mesh.faces)
            if not np.all(np.isfinite(vertices)):
                raise MeshError(f'{name}: a vertex is not finite')
            if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
                raise MeshError(f'{name}: a face names a vertex it does not have')
            if len(meshes) > 1:
                pieces = [mesh]
            else:  # its connected pieces (an STL's triangles share no vertices until merged)
                mesh.merge_vertices()
                groups = trimesh.graph.connected_components(mesh.face_adjacency,
                                                            nodes=np.arange(len(mesh.faces)))
                if len(groups) > MAX_PARTS:
                    raise MeshError(f'{name}: {len(groups)} pieces, more than MAX_PARTS = '
                                    f'{MAX_PARTS} (each one a collider of its body)')
                pieces = mesh.split(only_watertight=False) or [mesh]
            for piece in pieces:
                if decompose:
                    parts.extend(_convex_parts(name, piece))
                else:
                    parts.append(np.asarray(piece.vertices, dtype=np.float64))
                if len(parts) > MAX_PARTS:
                    raise MeshError(f'{name}: more than MAX_PARTS = {MAX_PARTS} parts (each '
                                    'one a collider of its body)')
        return parts
    except MeshError:
        raise
    except Exception as e:  # a parser's or its processing's error on bad bytes: any kind
        raise MeshError(f'{name}: not a readable mesh ({type(e).__name__}: '
                        f'{short(str(e))})') from None


def mesh_surface(name: str, roots: Sequence[Path], scale=1.0) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (V, 3) in m, the file's frame times ``scale``; triangles (T, 3) of vertex
    indices, as the file orders their corners) of the whole surface of the mesh file ``name``
    (every object of it, shared vertices merged): a terrain's. Read as ``mesh_parts`` reads."""
    path = resolve(name, roots)
    scale = _scale(name, scale)
    shown = _shown(name)
    try:
        data = path.read_bytes()[:MAX_BYTES + 1]
    except OSError as e:
        raise MeshError(f'{shown}: cannot be read ({type(e).__name__})') from None
    if len(data) > MAX_BYTES:
        raise MeshError(f'{shown}: more than MAX_BYTES = {MAX_BYTES}')
    try:
        import trimesh
    except ImportError:
        raise MeshError(f'{shown}: reading mesh files needs trimesh (pip install trimesh, or '
                        'rosdep: python3-trimesh)') from None
    try:
        found = [m for m in _file_meshes(trimesh, shown, data, path.suffix.lower()[1:])[0]
                 if len(m.faces)]
        if not found:
            raise MeshError(f'{shown}: holds no triangles')
        mesh = cast(trimesh.Trimesh,  # (concatenate is typed as any Geometry)
                    trimesh.util.concatenate(found) if len(found) > 1 else found[0])
        vertices = np.asarray(mesh.vertices, dtype=np.float64)
        if not np.all(np.isfinite(vertices)):
            raise MeshError(f'{shown}: a vertex is not finite')
        mesh.merge_vertices(merge_tex=True, merge_norm=True)  # (not split at UV seams)
        faces = np.asarray(mesh.faces, dtype=np.int64)
        # a triangle whose corners merged has no area: dropped, as the terrain drops those
        whole = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (
            faces[:, 0] != faces[:, 2])
        if not whole.any():
            raise MeshError(f'{shown}: every triangle has corners that coincide')
        return np.asarray(mesh.vertices, dtype=np.float64) * scale, faces[whole]
    except MeshError:
        raise
    except Exception as e:  # a parser's or its processing's error on bad bytes: any kind
        raise MeshError(f'{shown}: not a readable mesh ({type(e).__name__}: '
                        f'{short(str(e))})') from None


def _convex_parts(name: str, mesh) -> list[np.ndarray]:
    """The vertices of each convex part of ``mesh`` (coacd, threshold DECOMPOSE_THRESHOLD,
    seed 0)."""
    try:
        import coacd
    except ImportError:
        raise MeshError(f'{name}: decompose needs coacd (pip install coacd)') from None
    coacd.set_log_level('error')
    try:
        found = coacd.run_coacd(coacd.Mesh(np.asarray(mesh.vertices, dtype=np.float64),
                                           np.asarray(mesh.faces, dtype=np.int32)),
                                threshold=DECOMPOSE_THRESHOLD, seed=0)
    except Exception as e:  # its C++ refusing a mesh: any kind
        raise MeshError(f'{name}: coacd could not decompose it ({type(e).__name__}: '
                        f'{str(e)[:200]})') from None
    return [np.asarray(vertices, dtype=np.float64) for vertices, _ in found]


def _scale(name: str, scale) -> np.ndarray:
    values = np.atleast_1d(np.asarray(scale, dtype=object))
    if values.size not in (1, 3) or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        raise MeshError(f'{_shown(name)}: scale must be a number or 3 numbers, got '
                        f'{short(scale)}')
    out = np.broadcast_to(values.astype(np.float64), (3,)).copy()
    if not np.all(np.isfinite(out)) or not np.all(out > 0.0):
        raise MeshError(f'{_shown(name)}: scale must be finite and > 0, got {short(scale)}')
    return out


def hulls(parts: Sequence[np.ndarray], name: str, **placement) -> list[hull.Hull]:
    """One ``Hull`` of each part's points, with ``placement`` (position, orientation_xyzw,
    restitution, friction) each; MeshError naming the part that is not a solid."""
    out = []
    for k, points in enumerate(parts):
        try:
            out.append(hull.Hull(points, **placement))
        except ValueError as e:
            raise MeshError(f'{_shown(name)}: part {k}: {e}') from None
    return out


def combined_mass(shapes_: Sequence[hull.Hull],
                  density: float) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass, inertia about it) of the solid hulls ``shapes_`` (each placed in
    the frame they share) of uniform ``density``: their own, moved by the parallel-axis
    theorem and summed."""
    masses, centres, inertias = [], [], []
    for s in shapes_:
        m, c, inertia = s.mass_properties(density)
        r = s.rotation
        masses.append(m)
        centres.append(np.array(s.position) + r @ c)
        inertias.append(r @ inertia @ r.T)
    total = float(sum(masses))
    centre = sum(m * c for m, c in zip(masses, centres)) / total
    inertia = np.zeros((3, 3))
    for m, c, own in zip(masses, centres, inertias):
        d = c - centre
        inertia += own + m * (float(d @ d) * np.eye(3) - np.outer(d, d))
    return total, centre, 0.5 * (inertia + inertia.T)
