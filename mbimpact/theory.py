r"""The model mbimpact implements, with the corrections of the printed formulas.

Source: A. P. Ivanov, "A constructive model of impact with friction" (in Russian,
1988–89). Equation numbers (1.1)…(4.3) in the code, docstrings and tests are the
paper's. This module holds no code; ``help(mbimpact.theory)`` reads it.

1. Setting
----------
A mechanism has configuration ``q`` (Pinocchio's, tangent dimension ``nv``), velocity
``v`` and kinetic energy ``T = ½ vᵀ A(q) v`` with ``A`` symmetric positive definite
(``pin.crba``). A unilateral constraint ``f(q) ≥ 0`` is the distance between two
bodies; an impact starts when ``f = 0`` and ``ḟ = ∇f · v < 0``. During the impact the
configuration is frozen and only the velocity jumps; Lagrange's impact equations
(1.1) read ``A Δv = I`` with ``I`` the generalised impulse.

2. The metric and Newton's law
------------------------------
The kinetic energy defines the inner product (2.1) ``(a, b) = aᵀ A b``, which does not
depend on the choice of generalised coordinates. The normal of ``f = 0`` in this
metric is ``N = A⁻¹ ∇fᵀ``, with ``(N, v) = ḟ``. Newton's frictionless law (1.2) keeps
the tangential motion and reverses the normal one with restitution ``e``:
``Δv = −(1+e) (N, v) N / |N|²`` — exactly ``pin.impulseDynamics`` with one row.

3. A rough surface is a random set of facets
--------------------------------------------
The rough constraint is the base surface plus a small random relief ``g`` drawn from
a probability space ``(G, P)`` (2.2). At the contact point every realisation is a
*facet*: a small plane whose normal is tilted from the base normal ``n⁰``. All the
law needs from the relief is the distribution of the facet normals there.

In contact space: let ``J`` (d × nv, d = 3, or 2 for planar motion) be the
world-aligned translational Jacobian of the contact point, ``u = J v`` its velocity
and ``W = J A⁻¹ Jᵀ`` the Delassus matrix. A facet with unit physical normal ``m`` has
the constraint gradient ``mᵀJ``, so its metric normal and flux are

    N_m = A⁻¹ Jᵀ m / √(mᵀWm),        (N_m, v) = mᵀu / √(mᵀWm).

The measures of :mod:`mbimpact.roughness` are *physical*: ``P`` is the fraction of true
surface area with a given facet orientation. A segment of slope α over a horizontal
length ``h`` has length ``h / cos α``, and it is that length, not ``h``, that counts.

4. Kelvin–Voigt facets and the restitution ``e``
------------------------------------------------
While a facet is penetrated, the force (2.3) ``Q* = −(M² f + 2kM ḟ) ∇fᵀ`` acts
(``M ≫ 1`` a stiffness, ``0 ≤ k ≤ 1`` a damping ratio). With the normalisation of (2.2)
this gives ``f̈ = −(M² f + 2kM ḟ)``, solved in closed form (2.5): the contact lasts
``τ = π / (M √(1−k²))`` and leaves with ``ḟ = −e ḟ₀``,

    e = exp(−k π / √(1 − k²)),        k = −ln e / √(π² + ln² e),

independent of ``M`` (``mbimpact.e_from_k``, ``k_from_e``, ``impact_duration``). On one
facet the impact is therefore Newton's law along the facet's own normal:
``Δv = −(1+e) (N_m, v) N_m``. :func:`mbimpact.resolve` integrates (2.3) in time and
converges to it like 1/M.

5. The average (2.6)–(2.8)
--------------------------
The outcome is the average of the facet impacts, each weighted by the chance that the
trajectory meets that facet, proportional to its flux (2.7), over the facets that face
the motion, ``G* = {mᵀu < 0}``:

    (2.8)   Δv = −(1+e) ∫_{G*} (N,v)² N dP / ∫_{G*} (N,v) dP.

In contact space, with facets ``(mᵢ, pᵢ)`` and weights ``wᵢ``:

    P_c = −(1+e) Σ wᵢ (mᵢᵀu / mᵢᵀWmᵢ) mᵢ / Σ wᵢ,      Δv = A⁻¹ Jᵀ P_c,      I = Jᵀ P_c.

**Which weight is physical.** (2.7) weighs a facet by its flux through an element of
*configuration-space* area measured in the A-metric. A physical facet
``mᵀ(p(q) − p⁰) = g`` is a hypersurface of configuration space whose A-metric area is
its physical area times ``√(mᵀWm)`` (times a factor common to all facets). For a
physical measure ``P`` the weight of (2.7) is therefore

    wᵢ = pᵢ √(mᵢᵀWmᵢ) (−(Nᵢ, v)) = pᵢ (−mᵢᵀu)        (``flux="physical"``, the default):

the rate at which the contact point, moving along ``u``, sweeps facet ``i``. A direct
experiment — straight approaches of the contact point over a profile, each striking
the first facet it meets — reproduces this weight (the test suite checks it so).
The literal weight ``pᵢ (−(Nᵢ, v))`` (``flux="configuration"``) is right only when ``P``
is itself a measure on configuration-space area (e.g. ``J = I``). The two agree when
``W ∝ I``; for a planar rod end (cond W = 4) they differ by ~10 % in κ and μ.

**Range of validity.** The model assumes one micro-impact per facet. The average can
leave the mean contact velocity still moving into the surface (κ < 0): steep facets at
normal incidence do it once ``(1+e) E[cos³α] < E[cos α]``, and oblique impacts on an
anisotropic W do it too. Physically, further micro-impacts follow; ``result.separates``
says so and a :class:`mbimpact.NoSeparationWarning` is issued. ``RoughLaw(repeat=True)``
applies the law again until the contact separates; when the directions of the
successive velocities settle (a fixed direction, or a two-cycle between the walls of a
valley) the velocities shrink geometrically and the limit stops the contact point,
``P_c = −W⁺ u``.

**Friction ratio.** Results report ``μ = |P_t| / P_n`` read from the contact impulse.
For a point mass this is the paper's (3.1); for a mechanism, splitting the covector
``I`` into normal and tangential parts is not coordinate-free, so reading μ in contact
space is a choice.

6. Closed forms (as printed, with their misprints corrected)
-------------------------------------------------------------
*Isotropic roughness* (facet normal ``n⁰ cos α + l sin α``, ``l`` uniform and independent
of α; ``v = v_n n⁰ + v_l``, ``v_n < 0``, tangent dimension ``d−1``, ``E`` the mean over
facets; a point mass, or ``W ∝ I``). When ``|v_l| tan α_max < |v_n|`` every facet faces:

    Δv = (1+e)/E[cos α] · { n⁰ ( |v_n| E[cos³α] + |v_l|²/|v_n| · E[sin²α cos α]/(d−1) )
                            − 2 v_l E[sin²α cos α]/(d−1) }.

The printed (2.10) drops the ``l`` inside its last integral and reverses the sign of the
normal part: the corrected normal part points away from the surface and the
tangential part opposes ``v_l``.

*The planar sawtooth* (facets ``(∓sin α, cos α)``, ``P = ½`` each, ``tan β = |v_l|/|v_n|``):
normal incidence gives ``Δv = (1+e) |v_n| cos²α n⁰`` (2.11), i.e. ``κ = (1+e) cos²α − 1``.
For ``β < π/2 − α`` (2.12): ``Δv = (1+e) [ n⁰ (v_l² sin²α/|v_n| + |v_n| cos²α) − 2 v_l sin²α ]``.
For ``β ≥ π/2 − α`` (2.13, printed with ``<``) only the facet facing the motion is hit,
``Δv = (1+e)(|v_l| sin α + |v_n| cos α)(−sin α sgn v_l, cos α)``; its slope is
``g′ = +tan α sgn v_l`` (printed with a minus). The friction ratio (3.1) is
``μ = 2 tan²α tan β / (tan²α tan²β + 1)`` below the switch and ``tan α`` above (Fig. 1),
and ``κ = (1+e)(tan²β sin²α + cos²α) − 1`` below it: κ grows with the sliding speed and
can exceed 1 while the kinetic energy still decreases.

7. Properties (section 3), kept as tests
----------------------------------------
1° Δv is positively homogeneous of degree 1 in v. 2° On an isotropic surface the
tangential jump opposes the sliding and Δv lies in the plane of v and n⁰. 3° At normal
incidence the law is Newton's with ``1 + κ = (1+e) E[cos³α]/E[cos α]`` (4.2). 4° κ
depends on the incidence, grows with the sliding speed and may exceed 1. 5° Without
relief it is Newton's law with κ = e. Always: the kinetic energy never grows (each facet
impact loses ``½(1−e²)(N,v)²`` and averaging loses more, by convexity), and the physical
outcome does not depend on the generalised coordinates.

8. Section 4: a point on a vibrating rough surface of revolution
-----------------------------------------------------------------
A point bounces periodically along the axis of a rough surface of revolution that
oscillates vertically; ``m`` is the period of the motion in surface periods and ρ the
radius of curvature on the axis (ρ > 0: a cup, ρ < 0: a dome). Linearised about the
axis, an isotropic law gives ``Δv_l = −λ v_l`` with

    (4.1)  λ = 2(1+e) E[sin²α cos α] / ((d−1) E[cos α])

(the printed form has ``|∫(a_l, l) …|``, which vanishes identically; it needs
``(a_l, l)²``) and κ of (4.2). Over one period the horizontal motion is a 2×2 map with
determinant ``1 − λ`` and trace ``2 − λ − aT``, ``a = (1+κ−λ) g T / ((1+κ) ρ)``,
``T = 2πm/ω``. It is stable iff ``0 < λ < 2`` and (4.3)

    0 < ρ⁻¹ / B < 1,        B = (2−λ)(1+κ) / (2π² m² (1+κ−λ))      (ρ in units of g/ω²):

a cup with ``0 < ρ⁻¹ < B`` when ``B > 0``, and a **dome** with ``B < ρ⁻¹ < 0`` when
``B < 0`` (``1 + κ < λ``). The paper's remark that for ``1 + κ < λ ≤ 2`` no surface
stabilises the motion is wrong: the dome does. For spatial isotropic roughness
``λ = e − κ``, so ``B > 0`` whenever κ ≥ 0; the dome needs planar roughness (e.g. the
sawtooth α = 0.7 with e = 1). The vertical periodic motion must itself exist and be
stable, as for a ball on a vibrating table. The linearisation needs an isotropic
measure: with one tilted facet the motion along the axis does not exist.
"""
