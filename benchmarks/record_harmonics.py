"""What a record's daily harmonics allow of a homogeneous conducting soil, with no solver and no
fit of the surface: the check behind docs/VALIDATION.md section 5's "why kappa and C stay high".

For a homogeneous soil under a daily wave, at any depth z the temperature and the conductive
flux are T(z) = A exp(-(1 + i) z / d) and G(z) = e sqrt(omega / 2) (1 + i) T(z) (complex
amplitudes, d = sqrt(2 alpha / omega), e = sqrt(kappa C) the effusivity), whatever the surface
does. So
- two temperature sensors give the diffusivity alpha, by their amplitude ratio and by their
  phase lag (the two agree where the soil is homogeneous);
- a flux plate and a temperature sensor at the same depth give the effusivity,
  e = |G| / (|T| sqrt(omega)), and the flux must lead the temperature by exactly 3 h (pi/4);
- kappa = e sqrt(alpha), C = e / sqrt(alpha).

    PYTHONPATH=. python benchmarks/record_harmonics.py [CASE.toml ...]   (default runs/grass.toml)

It prints, per case window: each sensor's harmonic, alpha of each sensor pair, the plate's
effusivity and lead over the temperature at its depth (interpolated in log amplitude and in
phase between the two sensors around it), the kappa and C they imply, and the plate factor a
loam's largest effusivity (kappa 1.8 W m-1 K-1, C 3.2 MJ m-3 K-1) would need.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from pavement_mcmc.criticism.residuals import harmonic
from pavement_mcmc.data import load_case

REPO = Path(__file__).resolve().parents[1]
DAY = 86400.0
OMEGA = 2 * np.pi / DAY
LOAM_E = np.sqrt(1.8 * 3.2e6)  # the largest effusivity of the README's moist loam


def alpha_pair(a1, p1, a2, p2, dz):
    """Diffusivity (m2 s-1) from the amplitude ratio and from the phase lag over ``dz``."""
    lag = ((p2 - p1) % DAY) * OMEGA  # rad
    return OMEGA * dz**2 / (2 * np.log(a1 / a2) ** 2), OMEGA * dz**2 / (2 * lag**2)


def main(paths: list[str]) -> None:
    for path in paths:
        cfg = load_case(Path(path))
        m = cfg.measurements
        t = m.t
        print(f"{Path(path).name}: {m.n_obs} rows, {(t[-1] - t[0]) / 3600:.0f} h from {m.time0}")
        h = [harmonic(t, m.T_obs[:, k]) for k in range(m.n_sensors)]
        for lab, z, (a, p) in zip(m.sensor_labels, m.depths, h, strict=True):
            print(f"  {lab:>6s} ({z * 100:4.1f} cm): amplitude {a:.3f} K, maximum at {p / 3600:5.2f} h")
        for k in range(m.n_sensors - 1):
            (a1, p1), (a2, p2) = h[k], h[k + 1]
            dz = m.depths[k + 1] - m.depths[k]
            aa, ap = alpha_pair(a1, p1, a2, p2, dz)
            print(f"  alpha {m.sensor_labels[k]}-{m.sensor_labels[k + 1]}: {aa * 1e6:.2f} mm2/s "
                  f"(amplitude), {ap * 1e6:.2f} mm2/s (phase)")
        if m.G_obs is None:
            continue
        for j, zp in enumerate(m.flux_depths):
            ga, gp = harmonic(t, m.G_obs[:, j])
            k = int(np.clip(np.searchsorted(m.depths, zp) - 1, 0, m.n_sensors - 2))
            (a1, p1), (a2, p2) = h[k], h[k + 1]
            f = (zp - m.depths[k]) / (m.depths[k + 1] - m.depths[k])
            ta = float(np.exp((1 - f) * np.log(a1) + f * np.log(a2)))
            tp = p1 + f * ((p2 - p1) % DAY)
            e = ga / (ta * np.sqrt(OMEGA))
            lead = ((tp - gp) % DAY) / 3600
            print(f"  plate at {zp * 100:.1f} cm: amplitude {ga:.1f} W m-2, maximum at {gp / 3600:5.2f} h; "
                  f"leads the temperature there by {lead:.2f} h (a homogeneous soil: 3.00 h)")
            # the sensor pairs around the plate (both, where it sits on a sensor)
            near = [i for i in range(m.n_sensors - 1)
                    if m.depths[i] - 1e-9 <= zp <= m.depths[i + 1] + 1e-9]
            for i in near:
                (b1, q1), (b2, q2) = h[i], h[i + 1]
                aa, ap = alpha_pair(b1, q1, b2, q2, m.depths[i + 1] - m.depths[i])
                for name, a in (("amplitude", aa), ("phase", ap)):
                    print(f"    effusivity {e:.0f} J m-2 K-1 s-1/2, alpha {a * 1e6:.2f} mm2/s "
                          f"({m.sensor_labels[i]}-{m.sensor_labels[i + 1]}, {name}): kappa "
                          f"{e * np.sqrt(a):.2f} W m-1 K-1, C {e / np.sqrt(a) / 1e6:.2f} MJ m-3 K-1")
            print(f"    a loam's largest effusivity ({LOAM_E:.0f}) needs a plate factor of "
                  f"{e / LOAM_E:.2f} (reading / true flux)")


if __name__ == "__main__":
    main(sys.argv[1:] or [str(REPO / "runs" / "grass.toml")])
