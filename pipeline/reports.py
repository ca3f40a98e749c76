"""Console text of a steady flight and of a run, for each scene kind (the commands print it)."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from .classify import REGIMES


def _um(x: float) -> str:
    return f"{x * 1e6:.4f} um"


def rails_fly(steady: Any, scene: Any, wall: float) -> list[str]:
    sus = steady.suspension
    return [
        f"scene {scene.name} (calibration: {scene.calibration.mode})",
        f"  z                  {_um(steady.z)}",
        f"  pitch              {steady.pitch * 1e6:.3f} urad",
        f"  roll               {steady.roll * 1e6:.3f} urad",
        f"  minimum spacing    {_um(steady.min_spacing)} at x1 = {steady.min_spacing_x1 * 1e3:.3f} mm, "
        f"x2 = {steady.min_spacing_x2 * 1e3:.3f} mm",
        "  corner spacings    "
        + ", ".join(f"{c} {h * 1e6:.4f}" for c, h in zip("ABCD", steady.corner_spacings, strict=True)),
        f"  bearing number     {steady.bearing_number:.1f} (6 eta V L / (p0 h_min^2))",
        f"  load               {steady.load:.5f} N (preload in force {sus.preload:.5f} N)",
        f"  centre of pressure x1 = {steady.centre_of_pressure[0] * 1e3:.4f} mm, "
        f"x2 = {steady.centre_of_pressure[1] * 1e3:.4f} mm",
        f"  static moments     pitch {sus.static_pitch_moment:.4e} N m, roll {sus.static_roll_moment:.4e} N m",
        f"  work               {steady.reynolds_solves} steady Reynolds solves, "
        f"{steady.newton_iterations} Newton iterations, {wall:.2f} s",
    ]


def rails_run(result: Any, ds: xr.Dataset, scene: Any) -> list[str]:
    c = scene.contact
    lines = [
        f"scene {scene.name}: mu = {c.mu}, alpha = {c.alpha}, zdot0 = {scene.initial.zdot} m/s, "
        f"t_end = {scene.numerics.t_end * 1e6:.0f} us",
        f"  status {result.status}: {result.message}",
    ]
    thornton = c.restitution == "thornton"
    if thornton:
        lines.append(f"  restitution: alpha x Thornton's e_T, corner radius {c.corner_radius * 1e6:g} um, "
                     f"E* {c.contact_modulus / 1e9:g} GPa, p_y {c.yield_pressure / 1e9:g} GPa")  # fmt: skip
    for k, imp in enumerate(result.impacts):
        line = (f"  impact {k + 1:3d}  t = {imp.time * 1e6:8.3f} us  corner {imp.corner_letter}  "
                f"q = {imp.impulse * 1e6:.4f} uN s")  # fmt: skip
        if thornton:
            line += (f"  V = {imp.approach_before * 1e3:7.3f} mm/s  V_y = {imp.yield_velocity * 1e3:7.3f} mm/s  "
                     f"alpha = {imp.alpha:.4f}")  # fmt: skip
        lines.append(line)
    verdict = "STABLE" if int(ds["stable"]) else "UNSTABLE"
    w = result.work
    lines += [
        f"  {verdict}: {int(ds['n_impacts'])} impacts, {int(ds['n_larger_than_first'])} larger than the first, "
        f"{int(ds['n_front_corner_impacts'])} at front corners, max ratio {float(ds['max_impulse_ratio']):.3f}",
        f"  work: {w['steps']} steps, {w['newton_iterations']} Newton iterations, "
        f"{w['wall_time']:.2f} s ({w['wall_time'] / max(w['steps'], 1) * 1e3:.3f} ms/step)",
    ]
    return lines


def abs_fly(steady: Any, scene: Any, wall: float) -> list[str]:
    from solver.abs.steady import touchdown_text

    s, sf = scene.slider, steady.surface
    nx, ny = steady.pressure.shape
    return [
        f"scene {scene.name}: {s.length * 1e3:.2f} x {s.width * 1e3:.2f} mm, trailing pad "
        f"{s.trailing_pad_width * 1e6:.0f} um, preload {scene.suspension.preload * 1e3:.3f} mN, "
        f"{scene.disk.speed:.2f} m/s, skew {scene.disk.skew} deg, slip {scene.models.slip}",
        f"  flying height      {steady.element_spacing * 1e9:.4f} nm at the element "
        f"(x = {s.element_x * 1e3:.3f} mm, y = {s.element_y * 1e3:.3f} mm)",
        f"  pitch              {steady.q[1] * 1e6:.3f} urad",
        f"  roll               {steady.q[2] * 1e6:.4f} urad",
        f"  z at the pivot     {steady.q[0] * 1e9:.3f} nm",
        f"  minimum spacing    {steady.min_spacing * 1e9:.4f} nm at x = {steady.min_spacing_x * 1e3:.4f} mm, "
        f"y = {steady.min_spacing_y * 1e3:.4f} mm",
        f"  air-bearing force  {steady.air_force[0] * 1e3:.5f} mN",
        f"  contact force      {sf.contact * 1e3:.6f} mN, adhesion {sf.adhesion * 1e3:.6f} mN "
        f"(RMS {scene.disk.rms * 1e9:g} nm, delta_gamma {scene.contact.delta_gamma} J/m2, "
        f"{scene.models.adhesion} adhesion law)",
        f"  fold estimate      {touchdown_text(steady.touchdown_adhesion, scene.suspension.preload)}: the face "
        f"lowered {steady.touchdown_lowering * 1e9:.3f} nm at this pitch and roll to touch (lowest point at eps); "
        "near 1 preload or above, expect no flying equilibrium",
        *([f"  branch             contact: {steady.branch}"] if steady.branch else []),
        f"  work               grid {nx} x {ny}, {steady.iterations} attitude iterations, "
        f"{steady.reynolds_solves} sparse Reynolds solves on {steady.factorizations} LU factorizations, "
        f"{steady.wall_time:.2f} s",
        *region_table(steady, scene),
    ]


def region_table(steady: Any, scene: Any) -> list[str]:
    """What each region carries: load and pitch moment, each with its share of the same-sign total.

    The net values are small differences (the cavity's suction against the
    pads' lift; the nose-up against the nose-down moment, balanced by the
    suspension), so a share is taken of the regions pushing the same way: a
    pad's share of the lift, the cavity's of the suction, the trailing pad's
    of the nose-down moment.
    """
    from solver.abs.face import region_loads

    names, loads = region_loads(scene, steady.x, steady.y, steady.pressure)
    positive, negative = np.where(loads > 0, loads, 0).sum(axis=0), np.where(loads < 0, loads, 0).sum(axis=0)

    def share(value: float, column: int) -> str:
        total = positive[column] if value > 0 else negative[column]
        return f"{value / total:6.1%}" if total else "     -"

    width = max(len(n) for n in names + ["sum (node quadrature)"])
    lines = [
        "  loads by region (share: of the lift, or of the suction; of the nose-up, or of the nose-down moment)",
        f"  {'region':<{width}}  load [mN]   share  pitch moment [nN m]   share",
    ]
    for name, (f, mp, _) in zip(names, loads, strict=True):
        lines.append(f"  {name:<{width}}  {f * 1e3:9.4f}  {share(f, 0)}  {mp * 1e9:19.2f}  {share(mp, 1)}")
    total = loads.sum(axis=0)
    lines.append(
        f"  {'sum (node quadrature)':<{width}}  {total[0] * 1e3:9.4f}          {total[1] * 1e9:19.2f}   (the film's "
        f"force with its cut links: {steady.air_force[0] * 1e3:.4f} mN, {steady.air_force[1] * 1e9:.2f} nN m)"
    )
    return lines


def abs_run(result: Any, ds: xr.Dataset, scene: Any) -> list[str]:
    c, d, w = scene.contact, scene.disk, result.work
    return [
        f"scene {scene.name}: pad {scene.slider.trailing_pad_width * 1e6:.0f} um, RMS {d.rms * 1e9:g} nm, "
        f"delta_gamma {c.delta_gamma} J/m2, mu {c.mu}, preload {scene.suspension.preload * 1e3:.3f} mN, "
        f"t_end {scene.numerics.t_end * 1e3:g} ms",
        f"  status {result.status}: {result.message}",
        *_kick_line(scene),
        f"  steady flying height {float(ds['steady_flying_height']) * 1e9:.4f} nm",
        f"  regime               {REGIMES[int(ds['regime'])] if int(ds['regime']) >= 0 else 'not classified'}",
        f"  bouncing 3 sigma     {float(ds['bouncing_3sigma']) * 1e9:.4f} nm "
        f"(mean FH {float(ds['mean_flying_height']) * 1e9:.4f} nm)",
        f"  mean contact force   {float(ds['mean_contact_force']) * 1e3:.5f} mN "
        f"(max {float(ds['max_contact_force']) * 1e3:.4f} mN), contact fraction {float(ds['contact_fraction']):.3f}",
        f"  spectral peaks       FH {float(ds['fh_peak_frequency']) * 1e-3:.1f} kHz, pitch "
        f"{float(ds['pitch_peak_frequency']) * 1e-3:.1f} kHz, roll {float(ds['roll_peak_frequency']) * 1e-3:.1f} kHz",
        f"  work: {w['steps']} steps on {w['nodes']} nodes, {w['newton_iterations']} Newton iterations, "
        f"{w['wall_time']:.2f} s ({w['wall_time'] / max(w['steps'], 1) * 1e3:.3f} ms/step)",
        f"        {w['substeps']} substeps ({w['contact_substeps']} of split steps, {w['contact_damped']} with "
        f"rho_inf {scene.numerics.rho_infinity_contact:g}: contact too stiff for the finest), "
        f"{w['reynolds_solves']} Reynolds solves",
    ]


def _kick_line(scene: Any) -> list[str]:
    """The initial vertical velocity a run drew (initial.zdot_spread > 0), or nothing."""
    init = scene.initial
    if init.zdot_spread <= 0.0:
        return []
    zdot0 = init.velocities(scene.disk.seed)[0]
    return [
        f"  initial zdot         {zdot0:.4e} m/s ({init.zdot:g} + {init.zdot_spread:g} m/s x N(0, 1), seed "
        f"{scene.disk.seed})"
    ]


def rails_progress(record: dict[str, Any]) -> str:
    return f"{'stable  ' if record.get('stable') else 'unstable'} {record.get('n_impacts', 0):4d} impacts"


def abs_progress(record: dict[str, Any]) -> str:
    regime = REGIMES[record["regime"]] if record.get("regime", -1) >= 0 else "not classified"
    return (f"3sigma {record['bouncing_3sigma'] * 1e9:7.4f} nm, contact force "
            f"{record['mean_contact_force'] * 1e3:9.4g} mN, {regime}")  # fmt: skip
