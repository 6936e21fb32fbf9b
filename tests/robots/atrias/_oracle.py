"""The hand-written ATRIAS-like dynamics (mass matrix, bias, foot Jacobians, Cholesky solve)
that robots/atrias/robot.py carried before it was built on bipedlab.mechanics: kept here as
the independent oracle of the tree model (conventions of bipedlab.robots.atrias.robot)."""
import jax.numpy as jnp

NQ = 7
IX, IY, ITH, IG1, IG2, IL1, IL2 = range(7)


def hip(p, q):
    return jnp.stack([q[IX] - p.d * jnp.sin(q[ITH]), q[IY] - p.d * jnp.cos(q[ITH])])


def foot(p, q, i):
    g, l = q[IG1 + i], q[IL1 + i]
    return hip(p, q) + l * jnp.stack([jnp.sin(g), jnp.cos(g)])


def foot_jac(p, q, i):
    th, g, l = q[ITH], q[IG1 + i], q[IL1 + i]
    J = jnp.zeros((2, NQ))
    J = J.at[0, IX].set(1.0).at[1, IY].set(1.0)
    J = J.at[0, ITH].set(-p.d * jnp.cos(th)).at[1, ITH].set(p.d * jnp.sin(th))
    J = J.at[0, IG1 + i].set(l * jnp.cos(g)).at[1, IG1 + i].set(-l * jnp.sin(g))
    J = J.at[0, IL1 + i].set(jnp.sin(g)).at[1, IL1 + i].set(jnp.cos(g))
    return J


def foot_bias(p, q, qd, i):
    th, g, l = q[ITH], q[IG1 + i], q[IL1 + i]
    thd, gd, ld = qd[ITH], qd[IG1 + i], qd[IL1 + i]
    ax = p.d * jnp.sin(th) * thd ** 2 + 2 * ld * jnp.cos(g) * gd - l * jnp.sin(g) * gd ** 2
    ay = p.d * jnp.cos(th) * thd ** 2 - 2 * ld * jnp.sin(g) * gd - l * jnp.cos(g) * gd ** 2
    return jnp.stack([ax, ay])


def mass_matrix(p, q):
    M = jnp.diag(jnp.array([p.m, p.m, p.I_t, p.I_m, p.I_m, 0.0, 0.0]))
    for i in range(2):
        J = foot_jac(p, q, i)
        M = M + p.m_f * J.T @ J
    return M


def input_matrix():
    S = jnp.zeros((NQ, 4))
    S = S.at[IG1, 0].set(1.0).at[ITH, 0].set(-1.0).at[IG2, 1].set(1.0).at[ITH, 1].set(-1.0)
    return S.at[IL1, 2].set(1.0).at[IL2, 3].set(1.0)


def free_forces(p, q, qd, u):
    """Generalised forces other than the ground's: inputs, gravity, foot inertial bias."""
    f = input_matrix() @ u
    f = f.at[IY].add(-p.m * p.g)
    for i in range(2):
        J = foot_jac(p, q, i)
        f = f - p.m_f * J.T @ (foot_bias(p, q, qd, i) + jnp.array([0.0, p.g]))
    return f


def spd_solve(A, b):
    n = A.shape[0]
    L = [[None] * n for _ in range(n)]
    for j in range(n):
        s = A[j, j] - sum(L[j][k] * L[j][k] for k in range(j))
        L[j][j] = jnp.sqrt(s)
        for i in range(j + 1, n):
            L[i][j] = (A[i, j] - sum(L[i][k] * L[j][k] for k in range(j))) / L[j][j]
    y = []
    for i in range(n):
        y.append((b[i] - sum(L[i][k] * y[k] for k in range(i))) / L[i][i])
    x = [None] * n
    for i in reversed(range(n)):
        x[i] = (y[i] - sum(L[k][i] * x[k] for k in range(i + 1, n))) / L[i][i]
    return jnp.stack(x)
