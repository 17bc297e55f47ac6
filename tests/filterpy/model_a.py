"""Model A (SPEC section 3; seed 000, eqs 5.16-5.73, 6.1-6.5) written independently in Python,
with forward-mode dual numbers for its exact Jacobians.

This is the Python side of the filterpy comparison: it must not call the Rust code. It follows
SPEC section 3 plus the conventions the Rust vehicle model documents where SPEC leaves a choice:

- brake torque is a magnitude >= 0, the seed's M_B = -brake_torque;
- the sliding branch of the HSRI tyre, S, U *= (sRes - 0.25) / sRes**2 after dividing by (1 + s),
  is evaluated in the algebraically equal form C*x * mu*Fz/N * (1 - 0.25 * D/N) with
  N = sqrt((Cs s)^2 + (Ca tan a)^2), D = mu (1 + s) Fz (finite for a locked wheel);
- the divisor of slip and slip angle is at least 1 m/s (standstill guard; inactive in the tests);
- in the semi-implicit wheel step w + T wdot / (1 - T dwdot/dw) a positive dwdot/dw is taken as 0;
- derivative conventions of the dual numbers: d sqrt(x) = 0 at x = 0, d|x| = 0 at x = 0.
"""

import math

# Vehicle, 000 table 5.1 and the wheel loads after table 5.2 (SPEC section 3).
MASS = 1400.0
L_FRONT = 1.4346
L_REAR = 1.4831
YAW_INERTIA = 2978.7
FRONT_WHEEL_INERTIA = 10.3
REAR_WHEEL_INERTIA = 3.0
BRAKE_SPLIT_FRONT = 0.6
WHEEL_RADIUS = 0.3
FRONT_WHEEL_LOAD = 3492.0
REAR_WHEEL_LOAD = 3374.0
LOW_SPEED_GUARD = 1.0

# HSRI tyre, 000 table 5.2 (SPEC section 3).
FZ_REF = 3000.0
F00, F01 = 1.35, 0.15
KR0, KR1 = 0.1, 0.03
CA1, CA2 = 25.6, -5.73
CS1, CS2 = 10.0, 20.0
V_MU = 7.0


class Dual:
    """value + sum_i grad[i] eps_i; value and grad entries may themselves be Duals (nesting)."""

    __slots__ = ("value", "grad")

    def __init__(self, value, grad):
        self.value = value
        self.grad = grad

    @staticmethod
    def variable(value, index, size):
        grad = [0.0] * size
        grad[index] = 1.0
        return Dual(value, grad)

    def _lift(self, other):
        if isinstance(other, Dual):
            return other
        return Dual(other, [0.0] * len(self.grad))

    def __add__(self, other):
        o = self._lift(other)
        return Dual(self.value + o.value, [a + b for a, b in zip(self.grad, o.grad)])

    __radd__ = __add__

    def __sub__(self, other):
        o = self._lift(other)
        return Dual(self.value - o.value, [a - b for a, b in zip(self.grad, o.grad)])

    def __rsub__(self, other):
        return self._lift(other) - self

    def __neg__(self):
        return Dual(-self.value, [-a for a in self.grad])

    def __mul__(self, other):
        o = self._lift(other)
        return Dual(
            self.value * o.value,
            [a * o.value + self.value * b for a, b in zip(self.grad, o.grad)],
        )

    __rmul__ = __mul__

    def __truediv__(self, other):
        o = self._lift(other)
        q = self.value / o.value
        return Dual(q, [(a - q * b) / o.value for a, b in zip(self.grad, o.grad)])

    def __rtruediv__(self, other):
        return self._lift(other) / self

    def chain(self, f, df):
        return Dual(f, [a * df for a in self.grad])


def real(x):
    """The plain float inside a (possibly nested) dual."""
    while isinstance(x, Dual):
        x = x.value
    return x


def sqrt(x):
    if isinstance(x, Dual):
        root = sqrt(x.value)
        return x.chain(root, 1.0 / (2.0 * root) if real(root) > 0.0 else 0.0)
    return math.sqrt(x)


def sin(x):
    if isinstance(x, Dual):
        return x.chain(sin(x.value), cos(x.value))
    return math.sin(x)


def cos(x):
    if isinstance(x, Dual):
        return x.chain(cos(x.value), -sin(x.value))
    return math.cos(x)


def absolute(x):
    v = real(x)
    if v > 0.0:
        return x
    if v < 0.0:
        return -x
    if isinstance(x, Dual):
        # Derivative 0 at 0 (as the Rust dual numbers), value |x|.
        return Dual(absolute(x.value), [0.0] * len(x.grad))
    return abs(x)


def guarded(speed):
    return LOW_SPEED_GUARD if abs(real(speed)) < LOW_SPEED_GUARD else speed


def hsri_force(slip, tan_alpha, wheel_velocity, load):
    """Force of one wheel (longitudinal U, lateral S), SPEC section 3 / 000: 5.65-5.73."""
    q = load / FZ_REF
    f0 = F00 - F01 * q
    k_r = KR0 + KR1 * q
    sliding_speed = absolute(wheel_velocity) * sqrt(slip * slip + tan_alpha * tan_alpha)
    mu = f0 - k_r * sliding_speed / sqrt(sliding_speed * sliding_speed + V_MU * V_MU)
    c_alpha = (CA1 + CA2 * q) * load
    c_s = (CS1 + CS2 * q) * load
    lateral_demand = c_alpha * tan_alpha
    longitudinal_demand = c_s * slip
    numerator = sqrt(longitudinal_demand * longitudinal_demand + lateral_demand * lateral_demand)
    denominator = mu * (1.0 + slip) * load
    if real(numerator) <= 0.5 * real(denominator):
        # sRes <= 0.5: adhesion only.
        return longitudinal_demand / (1.0 + slip), lateral_demand / (1.0 + slip)
    factor = mu * load / numerator * (1.0 - 0.25 * denominator / numerator)
    return longitudinal_demand * factor, lateral_demand * factor


def axle(wheel_velocity, wheel_lateral_velocity, omega, load):
    divisor = guarded(wheel_velocity)
    tan_alpha = -wheel_lateral_velocity / divisor
    slip = (omega * WHEEL_RADIUS - wheel_velocity) / divisor
    fx, fy = hsri_force(slip, tan_alpha, wheel_velocity, load)
    return 2.0 * fx, 2.0 * fy


def axle_forces(vx, vy, r, w_front, w_rear, delta):
    c, s = cos(delta), sin(delta)
    lateral_at_front = vy + L_FRONT * r
    vx_front = vx * c + lateral_at_front * s
    vy_front = -(vx * s) + lateral_at_front * c
    fx_front, fy_front = axle(vx_front, vy_front, w_front, FRONT_WHEEL_LOAD)
    fx_rear, fy_rear = axle(vx, vy - L_REAR * r, w_rear, REAR_WHEEL_LOAD)
    return fx_front, fy_front, fx_rear, fy_rear, c, s


def step(x, u, dt):
    """The seed-000 discrete step (000: 6.1-6.5): explicit Euler for vx, vy, r; semi-implicit
    Euler for the wheel speeds with the exact d(wdot)/dw from a one-direction dual number."""
    vx, vy, r, w_front, w_rear = x
    delta, drive, brake = u
    seed_brake = -brake

    def inner(v):
        # Constant in the inner (wheel-speed) direction.
        return Dual(v, [0.0])

    fx_f, fy_f, fx_r, fy_r, c, s = axle_forces(
        inner(vx), inner(vy), inner(r), Dual(w_front, [1.0]), inner(w_rear), delta
    )
    # Rear axle force by its own wheel speed.
    _, _, fx_r, fy_r, _, _ = axle_forces(
        inner(vx), inner(vy), inner(r), inner(w_front), Dual(w_rear, [1.0]), delta
    )
    vy_dot = (fy_r.value + fy_f.value * c + fx_f.value * s) / MASS - vx * r
    vx_dot = (fx_r.value - fy_f.value * s + fx_f.value * c) / MASS + vy * r
    r_dot = (-fy_r.value * L_REAR + (fy_f.value * c + fx_f.value * s) * L_FRONT) / YAW_INERTIA
    wf_dot = (drive + BRAKE_SPLIT_FRONT * seed_brake - fx_f.value * WHEEL_RADIUS) / FRONT_WHEEL_INERTIA
    wr_dot = ((1.0 - BRAKE_SPLIT_FRONT) * seed_brake - fx_r.value * WHEEL_RADIUS) / REAR_WHEEL_INERTIA
    dwf = -(fx_f.grad[0] * WHEEL_RADIUS) / FRONT_WHEEL_INERTIA
    dwr = -(fx_r.grad[0] * WHEEL_RADIUS) / REAR_WHEEL_INERTIA

    def semi_implicit(w, rate, derivative):
        damping = derivative if real(derivative) < 0.0 else 0.0
        return w + rate * dt / (1.0 - damping * dt)

    return [
        vx + dt * vx_dot,
        vy + dt * vy_dot,
        r + dt * r_dot,
        semi_implicit(w_front, wf_dot, dwf),
        semi_implicit(w_rear, wr_dot, dwr),
    ]


def measurement(x, u):
    """y = [r, ay, wF, wR] with ay = vy_dot + vx r (000: 5.63, 5.40)."""
    vx, vy, r, w_front, w_rear = x
    fx_f, fy_f, fx_r, fy_r, c, s = axle_forces(vx, vy, r, w_front, w_rear, u[0])
    ay = (fy_r + fy_f * c + fx_f * s) / MASS
    return [r, ay, w_front, w_rear]


def jacobian(function, x, u):
    """d function / d x by forward-mode dual numbers (exact to rounding)."""
    n = len(x)
    duals = [Dual.variable(float(x[i]), i, n) for i in range(n)]
    out = function(duals, u)
    return [[float(real(g)) for g in y.grad] if isinstance(y, Dual) else [0.0] * n for y in out]
