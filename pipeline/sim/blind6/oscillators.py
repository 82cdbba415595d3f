"""Central pattern generator: four coupled Hopf oscillators (two legs, two arms)."""

import numpy as np


class HopfCPG:
    """z' = (alpha (mu - |z|^2) + i omega) z + sum_j k_ij (e^{i theta_ij} z_j - z_i).

    Index 0 left leg, 1 right leg, 2 left arm, 3 right arm.  The legs are coupled in
    anti-phase; each arm is locked in phase with the contralateral leg (so in anti-phase
    with its own leg) and weakly in anti-phase with the other arm.
    """

    def __init__(self, alpha=30.0, k_leg=3.0, k_arm=5.0):
        self.alpha = alpha
        C = np.zeros((4, 4), complex)
        for i, j, k, th in (
            (0, 1, k_leg, np.pi),
            (1, 0, k_leg, np.pi),
            (2, 1, k_arm, 0.0),
            (3, 0, k_arm, 0.0),
            (2, 3, 0.3 * k_arm, np.pi),
            (3, 2, 0.3 * k_arm, np.pi),
        ):
            C[i, j] += k * np.exp(1j * th)
        self.C = C
        self.kd = np.abs(C).sum(1)

    def deriv(self, z, mu, om):
        r2 = z.real**2 + z.imag**2
        return (self.alpha * (mu - r2) + 1j * om) * z + self.C @ z - self.kd * z

    def rk4(self, z, mu, om, dt):
        k1 = self.deriv(z, mu, om)
        k2 = self.deriv(z + 0.5 * dt * k1, mu, om)
        k3 = self.deriv(z + 0.5 * dt * k2, mu, om)
        k4 = self.deriv(z + dt * k3, mu, om)
        return z + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)


class OU:
    """Ornstein-Uhlenbeck process for rhythm jitter (relative frequency deviation)."""

    def __init__(self, sigma, tau, rng, clip=0.25):
        self.s, self.tau, self.rng, self.clip, self.x = sigma, tau, rng, clip, 0.0

    def step(self, dt):
        self.x += -self.x / self.tau * dt + self.s * np.sqrt(2 * dt / self.tau) * self.rng.standard_normal()
        self.x = float(np.clip(self.x, -self.clip, self.clip))
        return self.x
