"""VTK output for ParaView: one ``.vtu`` file per output time (written with meshio)
and a ``.pvd`` collection that ParaView opens as a time series.

Each file holds the centre line of every beam as a polyline through
``points_per_element`` points per active element (cells ``line``), with point data
``stress`` (bending stress on the outer fibre [Pa]), ``curvature`` (of the current
centre line, (r' × r'')/|r'|³ [1/m]) and ``axial_force`` (N = EA·ε [N]), and every
rigid body as a point (cells ``vertex``) with point data ``angle`` [rad]; ``beam``
and ``body`` number the beam or body of each point (−1: none).
"""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._deps import need


@eqx.filter_jit
def _beam_fields(beam, nodes, s):
    """Positions (N, P, 2), stress, curvature, axial force (N, P) at arc lengths s (P,)."""
    def at(nd, ss):
        r = beam.position(nd, ss)
        d1 = jax.jacfwd(beam.position, argnums=1)(nd, ss)
        d2 = jax.jacfwd(jax.jacfwd(beam.position, argnums=1), argnums=1)(nd, ss)
        kappa = (d1[0] * d2[1] - d1[1] * d2[0]) / jnp.linalg.norm(d1) ** 3
        return r, beam.stress(nd, ss), kappa, beam.axial_force(nd, ss)
    return jax.vmap(lambda nd: jax.vmap(lambda ss: at(nd, ss))(s))(nodes)


def write_vtk(results, out, *, points_per_element: int = 5, name: str = "run") -> Path:
    """Write ``results`` (a :class:`~ancf_jax.results.Results`) as ``out/NAME_XXXX.vtu``
    per output time and ``out/NAME.pvd``; returns the ``.pvd`` path."""
    meshio = need("meshio")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    system = results.system
    n_t = len(results.t)
    pts, conn, fields, beam_id = [], [], {"stress": [], "curvature": [], "axial_force": []}, []
    offset = 0
    for b, bname in enumerate(system.beam_names):
        beam = system.beams[b]
        n_el = int(beam.mesh.n_elements)
        arc = np.asarray(beam.mesh.node_arc_lengths)[: n_el + 1]
        xi = np.linspace(0.0, 1.0, points_per_element)[:-1]
        s = np.concatenate([arc[k] + xi * (arc[k + 1] - arc[k]) for k in range(n_el)] + [arc[-1:]])
        # points at element ends: just inside their element, so the last point is on the beam
        s = np.clip(s, 0.0, arc[-1] * (1 - 1e-12))
        r, sig, kap, nf = (np.asarray(a) for a in _beam_fields(beam, jnp.asarray(results.nodes(bname)),
                                                                  jnp.asarray(s)))
        pts.append(r)
        for k, a in zip(fields, (sig, kap, nf)):
            fields[k].append(a)
        conn.append(np.stack([np.arange(len(s) - 1), np.arange(1, len(s))], axis=1) + offset)
        beam_id.append(np.full(len(s), b))
        offset += len(s)
    n_beam_pts = offset
    bodies = [results.body(n) for n in system.body_names]
    pose = np.stack(bodies, axis=1) if bodies else np.zeros((n_t, 0, 3))
    xy = np.concatenate(pts + [pose[:, :, :2]], axis=1) if pts else pose[:, :, :2]
    points = np.concatenate([xy, np.zeros(xy.shape[:2] + (1,))], axis=2)
    n_b = pose.shape[1]
    cells = []
    if conn:
        cells.append(("line", np.concatenate(conn)))
    if n_b:
        cells.append(("vertex", (n_beam_pts + np.arange(n_b))[:, None]))
    pad = np.zeros((n_t, n_b))
    data = {k: np.concatenate(v + [pad], axis=1) if v else pad for k, v in fields.items()}
    data["angle"] = np.concatenate([np.zeros((n_t, n_beam_pts)), pose[:, :, 2]], axis=1)
    ids_beam = np.concatenate(beam_id + [np.full(n_b, -1)]) if beam_id else np.full(n_b, -1)
    ids_body = np.concatenate([np.full(n_beam_pts, -1), np.arange(n_b)])
    entries = []
    for i in range(n_t):
        file = f"{name}_{i:05d}.vtu"
        mesh = meshio.Mesh(points[i], cells, point_data={**{k: v[i] for k, v in data.items()},
                                                          "beam": ids_beam, "body": ids_body})
        meshio.write(out / file, mesh, file_format="vtu")
        entries.append(f'    <DataSet timestep="{float(results.t[i])!r}" group="" part="0" file={quoteattr(file)}/>')
    pvd = out / f"{name}.pvd"
    pvd.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
                   + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n")
    return pvd
