"""Image-based visual servoing (IBVS) in NumPy: the pieces of the law, in one place.

The law is the simplest IBVS one (Chaumette & Hutchinson 2006, eq. 3),
``qdot = -gain J^+ (s - s*) / dt``, written in joint space: ``J`` is the image Jacobian
d(pixel)/d(q) of the features in use, taken by central differences of a model that predicts every
feature's pixel at joints ``q`` (``Sim.project``), and ``J^+`` a damped (Levenberg-Marquardt)
pseudo-inverse. ``python/examples/ibvs.py`` closes the loop on ``Sim`` with these functions and
``synthcam.gym.IbvsPolicy`` runs the same law as a Gymnasium policy.

    from synthcam.servo import ibvs_velocity
    qdot = ibvs_velocity(sim.project, obs.q_rad, ids, (pixels - desired).reshape(-1))
    sim.command(qdot, 0.1)
"""

from typing import Any, Callable, Dict, List, Mapping, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

Project = Callable[[Sequence[float]], np.ndarray]
"""A model of the camera on the arm: joints (rad) -> (features, 2) pixels (NaN where not seen)."""

_Ids = Union[Sequence[int], npt.NDArray[np.integer]]


def image_jacobian(project: Project, q: Sequence[float], ids: _Ids, eps: float = 1e-6) -> npt.NDArray[np.float64]:
    """The image Jacobian d(pixel)/d(q) of the features ``ids`` at joints ``q``.

    Parameters
    ----------
    project : callable
        Joints (rad) -> (features, 2) model pixels (px), e.g. ``Sim.project``.
    q : sequence of float
        Joint positions, rad.
    ids : sequence of int
        The features to differentiate (indices into ``project``'s rows), in the order of the
        error vector.
    eps : float
        Half the central-difference step, rad.

    Returns
    -------
    ndarray, shape (2 * len(ids), len(q))
        px/rad; rows ``2k`` and ``2k + 1`` are feature ``ids[k]``'s u and v.
    """
    q0 = np.asarray(q, dtype=float)
    idx = np.asarray(ids, dtype=np.int64)
    jac = np.zeros((2 * len(idx), len(q0)))
    for k in range(len(q0)):
        qp, qm = q0.copy(), q0.copy()
        qp[k] += eps
        qm[k] -= eps
        d = (np.asarray(project(qp.tolist()))[idx] - np.asarray(project(qm.tolist()))[idx]) / (2 * eps)
        jac[:, k] = d.reshape(-1)
    return jac


def damped_step(jac: npt.NDArray[np.float64], error: npt.ArrayLike, damping: float = 100.0) -> npt.NDArray[np.float64]:
    """The damped least-squares joint step ``dq = (J^T J + damping I)^-1 J^T e`` (rad).

    Parameters
    ----------
    jac : ndarray, shape (2k, dof)
        Image Jacobian, px/rad (``image_jacobian``).
    error : array_like, shape (2k,)
        Stacked feature error ``s - s*``, px (u0, v0, u1, v1, ...).
    damping : float
        Levenberg-Marquardt damping, px^2/rad^2: keeps the step bounded near singularities.

    Returns
    -------
    ndarray, shape (dof,)
        The joint step (rad) that best explains ``error`` to first order; move by ``-gain`` times it.
    """
    e = np.asarray(error, dtype=float).reshape(-1)
    return np.linalg.solve(jac.T @ jac + damping * np.eye(jac.shape[1]), jac.T @ e)


def ibvs_velocity(
    project: Project,
    q: Sequence[float],
    ids: _Ids,
    error: npt.ArrayLike,
    gain: float = 0.3,
    damping: float = 100.0,
    dt_s: float = 0.1,
) -> npt.NDArray[np.float64]:
    """Joint velocities (rad/s) of the IBVS law ``qdot = -gain (J^T J + damping I)^-1 J^T e / dt_s``.

    Parameters
    ----------
    project : callable
        Joints (rad) -> (features, 2) model pixels (px), e.g. ``Sim.project``.
    q : sequence of float
        Current joint positions, rad.
    ids : sequence of int
        The features in use (detected now and known at the goal).
    error : array_like, shape (2 * len(ids),) or (len(ids), 2)
        Current minus desired pixels of those features, px.
    gain : float
        Fraction of the error removed per step (0 < gain <= 1).
    damping : float
        Damping of the pseudo-inverse, px^2/rad^2.
    dt_s : float
        The step the velocity is held for, s.

    Returns
    -------
    ndarray, shape (dof,)
        Joint velocities, rad/s (zeros when ``ids`` is empty).
    """
    if len(ids) == 0:
        return np.zeros(len(q))
    jac = image_jacobian(project, q, ids)
    return -gain * damped_step(jac, error, damping) / dt_s


def desired_pixels(goal: Any) -> Dict[int, npt.NDArray[np.float64]]:
    """The desired pixel of each feature id: from an observation of the goal view (anything with
    ``ids`` and ``pixels_px``, such as ``Sim.observe_goal()``) or a ``{id: (u, v)}`` mapping (px,
    OpenCV's convention)."""
    if isinstance(goal, Mapping):
        return {int(i): np.asarray(p, dtype=float).reshape(2) for i, p in goal.items()}
    return {int(i): np.asarray(p, dtype=float) for i, p in zip(goal.ids, goal.pixels_px)}


def matched_error(obs: Any, desired: Mapping[int, npt.NDArray[np.float64]]) -> Tuple[List[int], npt.NDArray[np.float64]]:
    """The ids detected in ``obs`` (anything with ``ids`` and ``pixels_px``) that have a desired
    pixel, and their stacked error ``(u - u*, v - v*, ...)`` (px), in ``obs.ids``'s order."""
    ids = [int(i) for i in obs.ids if int(i) in desired]
    if not ids:
        return [], np.zeros(0)
    where = {int(i): k for k, i in enumerate(obs.ids)}
    return ids, np.concatenate([obs.pixels_px[where[i]] - desired[i] for i in ids])


def rms_px(error: npt.ArrayLike) -> float:
    """RMS distance (px) of stacked pixel errors (u0, v0, u1, v1, ...): ``sqrt(mean_i |e_i|^2)``;
    ``inf`` for no feature."""
    e = np.asarray(error, dtype=float).reshape(-1, 2)
    return float(np.sqrt((e**2).sum(axis=1).mean())) if len(e) else float("inf")


__all__ = ["Project", "damped_step", "desired_pixels", "ibvs_velocity", "image_jacobian", "matched_error", "rms_px"]
