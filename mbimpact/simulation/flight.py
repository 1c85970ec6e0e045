"""Free flight: forward dynamics integrated step by step, every open contact watched on each step.

Pinocchio's forward dynamics (only the declared forces) is integrated by DOP853, in the chart
q = anchor ⊕ dq of the configuration manifold (re-anchored when dq grows past 1, so that a
spinning body never meets the chart's singularity). After every
accepted step the gap of every open contact is checked on the step's dense output — at the
step's ends, at interior points, and at the minimum of the gap wherever its rate changes sign
inside the step, so that grazing crossings are found too — and the first crossing is located
by root finding. A contact that has just struck is disarmed until its gap opens again, but a
disarmed contact that comes back below its surface is still an impact: a crossing is never
ignored.

Joint damping (and a PD's kd) makes the flight stiff: its velocities decay at a rate up to
:meth:`~mbimpact.simulation.run.RunState.damping_rate`, and an explicit method needs steps shorter
than a few times its inverse. Above :data:`STIFF_RATE` a flight is integrated by Radau (implicit,
L-stable, with dense output) instead of DOP853. The right-hand side reads the clock, so that
``max_wall_time`` holds inside a step too, and stops the run on a non-finite state instead of
handing it to the integrator.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from .impacts import Impacts
from .run import RunState, Stop

__all__ = ["FreeFlight"]

# interior points of a free step at which every open contact's gap is checked
SCAN_POINTS = 4

#: Damping rate [1/s] above which a flight is stiff and integrated by Radau. DOP853 is stable for
#: steps up to about 3 / rate: beyond 3e4 1/s (steps of 1e-4 s) it takes more time than Radau (a
#: double pendulum: equal at 4.5e4 1/s, 15x slower at 4.5e5 1/s), below it less.
STIFF_RATE = 3e4

# scipy's Runge–Kutta and Radau solvers warn below rtol = 100 ε and use that instead
_RTOL_MIN = 100 * np.finfo(float).eps


class FreeFlight:
    """The free-flight phase of a run: it advances the run's :class:`~mbimpact.simulation.run.RunState`
    and hands the events it finds to the run's :class:`~mbimpact.simulation.impacts.Impacts`."""

    def __init__(self, state: RunState, impacts: Impacts) -> None:
        self.state, self.impacts = state, impacts

    def free_phase(self, t0: float, q0: NDArray[np.float64], v0: NDArray[np.float64]
                   ) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
        scene, nv = self.state.scene, self.state.nv
        anchor = q0.copy()
        reached = [t0]  # the last accepted time, for messages

        def rhs(t: float, y: NDArray[np.float64]) -> NDArray[np.float64]:
            self.state.check_wall_time(reached[0])  # a step may take many evaluations (rejections, Radau's Newton)
            q, v = self.state.configuration(anchor, y[:nv]), y[nv:]
            a = self.state.acceleration(t, q, v)
            if self.state.euclidean:
                out = np.concatenate([v, a])
            else:
                try:
                    dq = np.linalg.solve(pin.dIntegrate(self.state.model, anchor, y[:nv], pin.ARG1), v)
                except np.linalg.LinAlgError:  # the chart's singularity, or a non-finite trial state
                    raise Stop("integration_error", f"free flight stopped at t = {reached[0]:.9g}: the chart of the "
                                                    f"configuration is singular at a trial state") from None
                out = np.concatenate([dq, a])
            # never a NaN or inf to the integrator: it would take a NaN step size and loop forever
            if not np.isfinite(out).all():
                raise Stop("integration_error", f"free flight stopped at t = {reached[0]:.9g}: the dynamics overflowed "
                                                f"(|v| up to {float(np.abs(v).max()):.3g} at a trial state)")
            return out

        y0 = np.concatenate([np.zeros(nv), v0])
        rtol = max(scene.rtol, _RTOL_MIN)
        atol = max(scene.rtol * 1e-3, 1e-15)
        rate = self.state.damping_rate(q0)
        # scipy's step-size control squares and divides by the state's scale: a huge (valid, finite) velocity
        # overflows there; a non-finite step size then stops the run below instead of warning
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            if rate > STIFF_RATE:
                from scipy.integrate import Radau

                self.state.work["stiff_flights"] += 1
                solver: Any = Radau(rhs, t0, y0, scene.duration, rtol=rtol, atol=atol, max_step=self.state.max_step)
            else:
                solver = self.state.DOP853(rhs, t0, y0, scene.duration, rtol=rtol, atol=atol, max_step=self.state.max_step)
        if not np.isfinite(solver.h_abs):
            raise Stop("integration_error", f"free flight stopped at t = {t0:.9g}: no finite first step "
                                            f"(|v| = {float(np.abs(v0).max()):.3g})")
        while True:
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                message = solver.step()
            reached[0] = solver.t
            if solver.status == "failed":
                raise Stop("integration_error", f"free flight stopped at t = {solver.t:.9g}: {message}")
            self.state.work["free_steps"] += 1
            dense = solver.dense_output()

            def state(t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
                y = dense(t)
                return self.state.configuration(anchor, y[:nv]), y[nv:]

            found = self.scan(state, solver.t_old, solver.t)
            t_end = found[0] if found else solver.t
            self.state.sample_until(state, t_end)
            if found:
                t_e, kind, which = found
                q, v = state(t_e)
                self.state.emit(t_e, q, v)  # the state just before the event, then just after
                v = self.impacts.at_event(t_e, q, v, kind, which)
                self.state.emit(t_e, q, v)
                return t_e, q, v
            self.state.check_limits(solver.t)
            if solver.status == "finished":
                q, v = state(solver.t)
                self.state.emit(solver.t, q, v)
                return solver.t, q, v
            if not self.state.euclidean and float(np.abs(solver.y[:nv]).max()) > 1.0:
                # far from the anchor the chart q = anchor ⊕ dq turns singular (a rotation by 2π):
                # a new flight from here, anchored at the current configuration
                q, v = state(solver.t)
                self.state.work["reanchor"] += 1
                return solver.t, q, v

    def scan(self, state: Any, ta: float, tb: float) -> tuple[float, str, list[int]] | None:
        """The first event of the open contacts on [ta, tb]: (time, kind, contacts), kind "crossing"
        (an impact) or "touch" (a disarmed contact back on its surface with no approach speed)."""
        from scipy.optimize import brentq

        ts = np.linspace(ta, tb, SCAN_POINTS + 2)
        values = []
        for t in ts:
            q_t, v_t = state(t)
            values.append(self.state.kin.rates(q_t, v_t, float(t)))
        gaps = np.array([g for g, _ in values])
        rates = np.array([r for _, r in values])
        tol = self.state.band  # above it, a contact is off its surface (armed again); 1e-3 of it: rounding
        first: tuple[float, str, list[int]] | None = None
        xtol = 4 * np.finfo(float).eps * max(1.0, abs(tb))

        def gap_of(i: int) -> Any:
            return lambda t: float(self.state.kin.gaps(state(t)[0], t)[i])

        def rate_of(i: int) -> Any:
            def rate(t: float) -> float:
                q, v = state(t)
                return float(self.state.kin.rates(q, v, t)[1][i])

            return rate

        def down(i: int, a: float, b: float, ga: float, ra: float) -> tuple[float, str]:
            """Where contact i's gap goes from ≥ 0 at a to < 0 at b. A gap that starts on the surface
            (the instant of the last event) first rises to an apex: the crossing is found after it,
            so that no event repeats itself; an apex still on the surface is a touch."""
            if ga <= 1e-3 * tol:
                if ra <= 0.0:
                    return a, "crossing" if ra < 0.0 else "touch"
                rate = rate_of(i)
                if rate(b) >= 0.0:  # still rising at b: the gap went below by rounding only
                    return a, "touch"
                apex = float(brentq(rate, a, b, xtol=xtol))
                if gap_of(i)(apex) <= 1e-3 * tol:
                    return apex, "touch"
                a = apex
            return float(brentq(gap_of(i), a, b, xtol=xtol)), "crossing"

        for i in range(self.state.nc):
            if self.state.active[i]:
                continue
            armed = self.state.armed[i]
            event: tuple[float, str] | None = None
            if not armed and gaps[0, i] < -1e-3 * tol and rates[0, i] < 0:
                # already coming back below its surface (not merely 0 ± rounding, where a contact that lifted
                # off by itself starts: the steps below find it if it does come back)
                event = (ta, "crossing")
            for k in range(1, len(ts)):
                if event is not None:
                    break
                if not armed and gaps[k - 1, i] > tol:
                    armed = True
                g0, g1, r0, r1 = gaps[k - 1, i], gaps[k, i], rates[k - 1, i], rates[k, i]
                if armed:
                    if g0 >= 0.0 > g1:
                        event = down(i, ts[k - 1], ts[k], g0, r0)
                    elif g0 >= 0.0 and g1 >= 0.0 and r0 < 0.0 < r1:  # a minimum inside: a grazing crossing?
                        t_min = brentq(rate_of(i), ts[k - 1], ts[k], xtol=xtol)
                        if gap_of(i)(t_min) < 0.0:
                            event = down(i, ts[k - 1], t_min, g0, r0)
                elif g1 < 0.0 and r1 < 0.0:  # disarmed, and back below the surface while approaching
                    if g0 >= -1e-3 * tol:  # from on or above it (the last event left it at 0 ± rounding)
                        event = down(i, ts[k - 1], ts[k], g0, r0)
                    elif r0 >= 0.0:  # it never left: back on the surface with no approach speed
                        event = (brentq(rate_of(i), ts[k - 1], ts[k], xtol=xtol), "touch")
                    else:
                        event = (ts[k - 1], "crossing")
            if event is not None and (first is None or event[0] < first[0]):
                first = (event[0], event[1], [i])
            elif event is None:
                self.state.armed[i] = armed
        if first is not None:
            for i in range(self.state.nc):  # arming up to the event only
                if not self.state.active[i] and not self.state.armed[i]:
                    self.state.armed[i] = bool(np.any(gaps[ts <= first[0], i] > tol))
        return first
