"""The two symbolic loops of polarized path replay (docs/path-replay.md).

:func:`trace` follows the paths of Mitsuba's ``path`` integrator exactly (the
same random numbers in the same order, emitter sampling with MIS, Russian
roulette, Mueller matrices in the implicit Stokes bases of world directions)
and returns each sample's Stokes vector. Given a :class:`VertexStore`, it also
writes into Dr.Jit local memory, per sample and per vertex, what the replay
needs: how to rebuild the surface interaction, the random numbers of the
emitter and BSDF samples and the adjoint ``delta_k`` (reverse mode) or prefix
throughput ``beta_k`` (forward mode).

:func:`replay` walks the stored vertices backwards, differentiates each
vertex alone: ``delta_k . (E_k(theta) + T_k(theta) L_{k+1})``, and forms the
radiance arriving from the rest of the path ``L_{k+1}`` by ``L_k = E_k + W_k
L_{k+1}``, the sampled BSDF weight ``W_k`` (Mueller) being ``T_k``'s value.
Local memory lives per lane inside the kernel: nothing grows with
the number of samples.

Stokes vectors are ``mi.SpectrumEntry`` (4 components, each an
``UnpolarizedSpectrum``); Mueller matrices are ``mi.Spectrum``.
"""

from __future__ import annotations


import drjit as dr
import mitsuba as mi

from ..mueller import rotator_entries, to_world_mueller

__all__ = ["VertexStore", "trace", "replay", "column0", "mueller_times",
           "times_mueller"]


# ------------------------------------------------------------ Stokes algebra

def column0(m):
    """First column of a Mueller matrix: what it does to unpolarized light of
    unit radiance. An emitter's Mueller matrix carries its Stokes vector there
    (an unpolarized one is ``depolarizer(le)``; ``polarized_sky`` and the other
    polarized emitters fill the whole column)."""
    return mi.SpectrumEntry(m[0][0], m[1][0], m[2][0], m[3][0])


def mueller_times(m, s):
    """Mueller matrix ``m`` times Stokes vector ``s`` (per wavelength)."""
    return mi.SpectrumEntry(*[dr.fma(m[i][0], s[0], dr.fma(m[i][1], s[1],
                                     dr.fma(m[i][2], s[2], m[i][3] * s[3])))
                              for i in range(4)])


def times_mueller(d, m):
    """Row Stokes vector ``d`` times Mueller matrix ``m`` (an adjoint moving
    one vertex away from the camera)."""
    return mi.SpectrumEntry(*[dr.fma(d[0], m[0][j], dr.fma(d[1], m[1][j],
                                     dr.fma(d[2], m[2][j], d[3] * m[3][j])))
                              for j in range(4)])


def world_mueller_times(si, m, wo_local, wi_local, s):
    """``to_world_mueller(si, m, wo_local, wi_local)`` times the world-basis
    Stokes vector ``s``: ``R_out (m (R_in^T s))``, rotating two Stokes vectors
    instead of the 4 x 4 matrix ``m`` (per wavelength)."""
    in_forward, out_forward = si.to_world(wo_local), si.to_world(wi_local)
    ci, si_ = rotator_entries(in_forward, si.to_world(mi.mueller.stokes_basis(wo_local)),
                              mi.mueller.stokes_basis(in_forward))
    co, so = rotator_entries(out_forward, si.to_world(mi.mueller.stokes_basis(wi_local)),
                             mi.mueller.stokes_basis(out_forward))
    t = mueller_times(m, mi.SpectrumEntry(s[0], ci * s[1] - si_ * s[2],
                                          si_ * s[1] + ci * s[2], s[3]))
    return mi.SpectrumEntry(t[0], co * t[1] + so * t[2], co * t[2] - so * t[1], t[3])


def stokes_dot(d, s):
    """``sum_i d_i s_i`` per wavelength (an ``UnpolarizedSpectrum``)."""
    return dr.fma(d[0], s[0], dr.fma(d[1], s[1], dr.fma(d[2], s[2], d[3] * s[3])))


def mis_weight(pdf_a, pdf_b):
    """Power heuristic, detached, 0 where undefined (as Mitsuba's ``path``)."""
    a2, b2 = dr.square(pdf_a), dr.square(pdf_b)
    w = a2 / (a2 + b2)
    return dr.detach(dr.select(dr.isfinite(w), w, 0.0))


# ------------------------------------------------------------ local memory

class VertexStore:
    """Per-lane local-memory arrays of ``size`` vertex records.

    ``adjoint`` is ``"reverse"`` (store the row adjoint ``delta_k``, a Stokes
    vector) or ``"forward"`` (store the prefix throughput ``beta_k``, a
    Mueller matrix). Floats per vertex: 28 + 16 or 64 (~0.2 or 0.4 kB). The
    sampled weight ``W_k`` is not stored: the replay evaluates it anyway (with
    derivatives) and reads its value there."""

    @staticmethod
    def fields(adjoint):
        """Field name -> Dr.Jit type, in the active variant."""
        return {
            # rebuild the surface interaction: ray and preliminary intersection
            "o": mi.Point3f, "d": mi.Vector3f, "t": mi.Float, "prim_uv": mi.Point2f,
            "prim_index": mi.UInt32, "shape_index": mi.UInt32, "shape": mi.UInt32,
            "instance": mi.UInt32,
            # emission: MIS weight of the BSDF sample that hit this vertex
            "mis_bsdf": mi.Float,
            # emitter sample: random numbers, whether it counts (visible), MIS weight
            "em_sample": mi.Point2f, "em_ok": mi.UInt32, "mis_em": mi.Float,
            # BSDF sample: random numbers, direction, pdf, type, Russian roulette
            "bsdf_s1": mi.Float, "bsdf_s2": mi.Point2f, "wo": mi.Vector3f, "pdf": mi.Float,
            "smooth": mi.UInt32, "next": mi.UInt32, "rr": mi.Float,
            # delta_k (reverse mode) or beta_k (forward mode)
            "adj": mi.SpectrumEntry if adjoint == "reverse" else mi.Spectrum,
        }

    def __init__(self, size, adjoint):
        self.size = int(size)
        self.adjoint = adjoint
        self.buffers = {name: dr.alloc_local(tp, self.size)
                        for name, tp in self.fields(adjoint).items()}

    def write(self, k, **values):
        """Write record ``k``; returns :attr:`buffers`, which a symbolic loop
        that writes must keep as its loop state (:func:`trace`)."""
        for name, value in values.items():
            self.buffers[name][k] = value
        return self.buffers

    def read(self, k):
        return {name: buf[k] for name, buf in self.buffers.items()}


def _preliminary(rec):
    """The preliminary intersection stored in a vertex record."""
    pi = dr.zeros(mi.PreliminaryIntersection3f)
    pi.t = rec["t"]
    pi.prim_uv = rec["prim_uv"]
    pi.prim_index = rec["prim_index"]
    pi.shape_index = rec["shape_index"]
    pi.shape = dr.reinterpret_array(mi.ShapePtr, rec["shape"])
    pi.instance = dr.reinterpret_array(mi.ShapePtr, rec["instance"])
    pi.valid = dr.isfinite(rec["t"])
    return pi


# ------------------------------------------------------------ the loops

@dr.syntax
def trace(integrator, scene, sampler, ray, store=None, delta0=None):
    """Trace the paths of ``ray`` as Mitsuba's ``path`` does.

    Returns ``(stokes, valid, count)``: the Stokes vector of each sample in
    the implicit basis of ``-ray.d``, whether the ray counts (``path``'s
    ``valid_ray``) and the number of loop iterations (vertices stored). With
    a ``store``, writes each vertex record; ``delta0`` (reverse mode) is the
    camera adjoint, multiplied by the throughput to give ``delta_k``.

    In reverse mode the replay needs no Stokes vector: ``stokes`` is then
    zero, and the loop carries two rows of the throughput instead of the
    4 x 4 Mueller matrix (per wavelength), ``delta_k`` and the first row
    (whose first entry, the unpolarized throughput, drives Russian
    roulette): two vector-matrix products per vertex instead of a
    matrix-matrix product, and no emitted light evaluated."""
    ctx = mi.BSDFContext()
    max_depth, rr_depth = integrator.max_depth, integrator.rr_depth
    reverse = store is not None and store.adjoint == "reverse"

    ray = mi.Ray3f(dr.detach(ray))
    width = dr.width(ray)
    depth = mi.UInt32(0)
    count = mi.UInt32(0)
    beta = None if reverse else mi.Spectrum(1.0)
    rows = (mi.SpectrumEntry(mi.UnpolarizedSpectrum(1.0), 0.0, 0.0, 0.0),
            mi.SpectrumEntry(delta0)) if reverse else None
    stokes = dr.zeros(mi.SpectrumEntry, width)
    eta = mi.Float(1.0)
    valid_ray = mi.Bool((not integrator.hide_emitters) and scene.environment() is not None)
    prev_si = dr.zeros(mi.Interaction3f)
    prev_pdf = mi.Float(1.0)
    prev_delta = mi.Bool(True)
    active = mi.Bool(max_depth > 0)
    # The local arrays are loop state (assigned in the body): Dr.Jit records
    # the body twice when it finds loop-invariant state, and writes made
    # outside the state would keep the first recording's computation in the
    # kernel (the whole iteration, computed twice).
    buffers = store.buffers if store is not None else None
    pi = scene.ray_intersect_preliminary(ray, coherent=True, reorder=False, active=active)

    if dr.hint(integrator.hide_emitters, mode="scalar"):
        # as `path`: the camera ray passes through area emitters it hits first
        skip = pi.is_valid() & (pi.shape.emitter() != None) & active  # noqa: E711
        si_skip = pi.compute_surface_interaction(ray, mi.RayFlags.Minimal, skip)
        pi_after = integrator.skip_area_emitters(scene, si_skip.spawn_ray(ray.d), True, skip)
        pi[skip] = pi_after

    while dr.hint(active, max_iterations=max_depth, label="stokes_prb trace"):
        si = pi.compute_surface_interaction(ray, mi.RayFlags.All)

        # ---- emission, MIS against the emitter sample of the previous vertex
        ds = mi.DirectionSample3f(scene, si=si, ref=prev_si)
        em_pdf = scene.pdf_emitter_direction(prev_si, ds, ~prev_delta)
        mis_bsdf = dr.select(prev_pdf > 0, mis_weight(prev_pdf, em_pdf), 0.0)
        if dr.hint(not reverse, mode="scalar"):
            E = column0(ds.emitter.eval(si, prev_pdf > 0)) * mis_bsdf
        else:
            E = dr.zeros(mi.SpectrumEntry, width)  # not needed: no Stokes estimate

        active_next = (depth + 1 < max_depth) & si.is_valid()
        if dr.hint(reverse, mode="scalar"):
            adj_k = mi.SpectrumEntry(rows[1])
        else:
            beta_k = mi.Spectrum(beta)

        # What a path that ends at this vertex leaves: no emitter sample, no
        # BSDF sample. The rest is a symbolic `if`, which a SIMD packet whose
        # paths all end here skips.
        em_sample = dr.zeros(mi.Point2f, width)
        active_em = mi.Bool(False)
        mis_em = dr.zeros(mi.Float, width)
        s1 = dr.zeros(mi.Float, width)
        s2 = dr.zeros(mi.Point2f, width)
        bs = dr.zeros(mi.BSDFSample3f, width)
        rr = dr.ones(mi.Float, width)
        active_cont = mi.Bool(False)
        ray_next = mi.Ray3f(ray)

        if active_next:
            bsdf = si.bsdf(ray)

            # ---- emitter sampling (visibility tested here, stored for the replay)
            active_em = active_next & mi.has_flag(bsdf.flags(), mi.BSDFFlags.Smooth)
            em_sample = sampler.next_2d()
            ds, em_weight = scene.sample_emitter_direction(si, em_sample, False, active_em)
            active_em &= ds.pdf != 0.0
            active_em &= ~scene.ray_test(si.spawn_ray_to(ds.p), active_em)
            wo_em = si.to_local(ds.d)

            # ---- BSDF: value towards the emitter sample, and a sampled direction
            s1 = sampler.next_1d()
            s2 = sampler.next_2d()
            f_em, pdf_em, bs, weight = bsdf.eval_pdf_sample(ctx, si, wo_em, s1, s2)
            mis_em = dr.select(ds.delta, 1.0, mis_weight(ds.pdf, pdf_em))
            if dr.hint(not reverse, mode="scalar"):
                f_em = to_world_mueller(si, f_em, -wo_em, si.wi)
                E = dr.select(active_em, E + mueller_times(f_em, column0(em_weight)) * mis_em, E)

            weight = to_world_mueller(si, weight, -bs.wo, si.wi)
            ray_next = si.spawn_ray(si.to_world(bs.wo))
            if dr.hint(reverse, mode="scalar"):
                rows = (times_mueller(rows[0], weight), times_mueller(rows[1], weight))
                beta_max = dr.max(rows[0][0])
            else:
                beta *= weight
                beta_max = dr.max(mi.unpolarized_spectrum(beta))
            eta *= bs.eta
            prev_si = mi.Interaction3f(si)
            prev_pdf = bs.pdf
            prev_delta = mi.has_flag(bs.sampled_type, mi.BSDFFlags.Delta)

            # ---- Russian roulette (as `path`: after the depth increment)
            depth += 1
            rr_prob = dr.minimum(beta_max * dr.square(eta), 0.95)
            rr_active = depth >= rr_depth
            rr_continue = sampler.next_1d() < rr_prob
            rr = dr.select(rr_active, dr.rcp(rr_prob), 1.0)
            if dr.hint(reverse, mode="scalar"):
                rows = (rows[0] * rr, rows[1] * rr)
            else:
                beta *= rr
            active_cont = (~rr_active | rr_continue) & (beta_max != 0.0)

        if dr.hint(not reverse, mode="scalar"):
            stokes += mueller_times(beta_k, E)
        valid_ray |= active & si.is_valid() & ~mi.has_flag(bs.sampled_type, mi.BSDFFlags.Null)

        if dr.hint(store is not None, mode="scalar"):
            buffers = store.write(
                count, o=ray.o, d=ray.d, t=pi.t, prim_uv=pi.prim_uv, prim_index=pi.prim_index,
                shape_index=pi.shape_index, shape=dr.reinterpret_array(mi.UInt32, pi.shape),
                instance=dr.reinterpret_array(mi.UInt32, pi.instance), mis_bsdf=mis_bsdf,
                em_sample=em_sample, em_ok=dr.select(active_em, 1, 0), mis_em=mis_em,
                bsdf_s1=s1, bsdf_s2=s2,
                wo=bs.wo, pdf=bs.pdf,
                smooth=dr.select(mi.has_flag(bs.sampled_type, mi.BSDFFlags.Smooth), 1, 0),
                next=dr.select(active_cont, 1, 0), rr=rr,
                adj=adj_k if reverse else beta_k)
        count += 1
        active = active_cont
        ray = ray_next
        pi = scene.ray_intersect_preliminary(ray, coherent=False, reorder=False,
                                             active=active)

    return dr.select(valid_ray, stokes, 0.0), valid_ray, count


@dr.syntax
def replay(integrator, scene, ray, store, count, valid, differentiate_delta):
    """Walk the ``count`` stored vertices of each sample backwards and
    differentiate each one alone (see the module docstring).

    Reverse mode: back-propagates ``delta_k . (E_k + T_k L_{k+1})`` into the
    scene parameters and returns ``None``. Forward mode: returns the tangent
    Stokes vector ``sum_k beta_k (dE_k + dT_k L_{k+1})``.
    ``differentiate_delta``: also re-sample (with derivatives) the vertices
    whose BSDF sample is not smooth (delta, null: polarizers, smooth
    conductors), whose weight ``eval`` cannot give."""
    ctx = mi.BSDFContext()
    reverse = store.adjoint == "reverse"
    ray = mi.Ray3f(dr.detach(ray))
    width = dr.width(ray)
    L = dr.zeros(mi.SpectrumEntry, width)
    tangent = dr.zeros(mi.SpectrumEntry, width)
    # One index for all lanes (a scalar loop variable): local memory is then
    # read a packet at a time instead of gathered; lanes whose path is
    # shorter skip the first iterations (`here`). The body is a symbolic
    # `if`: on the CPU a SIMD packet none of whose paths is that long skips
    # it whole (about a third of the iterations in benchmarks/gradient_profile.md).
    k = mi.UInt32(store.size)

    while dr.hint(k > 0, label="stokes_prb replay"):
        k -= 1
        here = k < count
        if here:
            rec = store.read(k)
            ray_k = mi.Ray3f(ray)
            ray_k.o = rec["o"]
            ray_k.d = rec["d"]
            pi = _preliminary(rec)
            pi.valid &= here
            em_ok = (rec["em_ok"] != 0) & here
            has_next = (rec["next"] != 0) & here
            smooth = rec["smooth"] != 0
            mis_bsdf = dr.select(here, rec["mis_bsdf"], 0.0)

            with dr.resume_grad():
                si = pi.compute_surface_interaction(ray_k, mi.RayFlags.All)
                bsdf = si.bsdf(ray_k)

                # emission (this vertex's emitter, MIS weight from the trace)
                emitter = si.emitter(scene)
                E = column0(emitter.eval(si, mis_bsdf > 0)) * mis_bsdf
                # emitter sample again from its random numbers (derivatives of
                # the emitter's radiance); visibility and MIS weight as traced
                ds, em_weight = scene.sample_emitter_direction(si, rec["em_sample"], False, em_ok)
                wo_em = si.to_local(ds.d)
                le_em = column0(em_weight)

                # the BSDF towards the emitter sample and along the sampled
                # direction (f(theta) / pdf: detached sampling) ...
                wo = rec["wo"]
                pdf = rec["pdf"]
                f_em = bsdf.eval(ctx, si, wo_em, em_ok)
                f = bsdf.eval(ctx, si, wo, has_next & smooth)
                E[em_ok] = E + world_mueller_times(si, f_em, -wo_em, si.wi, le_em) * rec["mis_em"]
                scale = dr.select(has_next & smooth & (pdf > 0), rec["rr"] / pdf, 0.0)
                TL = world_mueller_times(si, f, -wo, si.wi, L * scale)
                if dr.hint(differentiate_delta, mode="scalar"):
                    # ... or, for delta and null lobes, the sampled weight itself
                    use = has_next & ~smooth
                    _, w = bsdf.sample(ctx, si, rec["bsdf_s1"], rec["bsdf_s2"], use)
                    TL[use] = world_mueller_times(si, w, -wo, si.wi, L * rec["rr"])
                contribution = E + TL

                if dr.hint(reverse, mode="scalar"):
                    adj = dr.select(valid, rec["adj"], 0.0)
                    dr.backward_from(stokes_dot(adj, contribution))
                else:
                    tangent += dr.forward_to(mueller_times(rec["adj"], contribution))

            # W_k L_{k+1} = T_k L_{k+1}'s value: W_k is the BSDF's sampled weight
            # f / pdf (roulette included)
            L = dr.select(here, dr.detach(contribution), L)

    if dr.hint(reverse, mode="scalar"):
        return None
    return dr.select(valid, tangent, 0.0)
