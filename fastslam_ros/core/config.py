"""Settings of the FastSLAM core, validated once at construction.

Every field is a plain number or string so that the ROS node can declare one parameter per
field with the same name. ``validate()`` raises ``ValueError`` whose message starts with the
field's name, so a bad YAML value is reported by the name the user typed.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

ALGORITHMS = ("fastslam1", "fastslam2")
ASSOCIATION_MODES = ("known", "ml", "monte_carlo", "two_gate")
RESAMPLING_SCHEMES = ("systematic", "stratified", "residual", "multinomial")
BEST_PARTICLE_RULES = ("heaviest", "central")
MONTE_CARLO_WEIGHTS = ("marginal", "sampled")
BACKENDS = ("auto", "numpy", "numba")


@dataclass(frozen=True)
class FastSLAMConfig:
    """All tunables of the filter (SI units, radians)."""

    num_particles: int = 100
    """M, the number of particles."""
    algorithm: str = "fastslam2"
    """``fastslam1`` (pose from the motion model) or ``fastslam2`` (pose from the proposal)."""
    association: str = "ml"
    """``known`` (ids given), ``ml`` (maximum likelihood with p0), ``monte_carlo`` (sampled),
    ``two_gate`` (Mahalanobis gates)."""
    new_landmark_likelihood: float = 1e-4
    """p0: likelihood density (1/(m rad)) below which an observation starts a new landmark; the
    weight of a particle that creates a landmark is multiplied by p0."""
    monte_carlo_weight: str = "marginal"
    """The weight factor of a sampled association (``monte_carlo``): ``marginal``, the sum of
    the likelihoods and p0, which is the importance weight of the draw and does not depend on
    the landmark drawn; or ``sampled``, the likelihood of the landmark drawn (p0 for a new one),
    which penalises an unlikely draw at once. On MRCLAM's clustered landmarks the marginal is
    better at M = 100 but got worse with more particles; the sampled likelihood did not
    (docs/datasets.md, session 10)."""
    association_gate: float = 9.21
    """two_gate: squared Mahalanobis distance inside which an observation may be associated
    (chi-square, 2 dof; 9.21 = 99 %)."""
    new_landmark_gate: float = 25.0
    """two_gate: squared Mahalanobis distance beyond which (from every landmark) a new landmark
    is created; between the two gates the observation is ignored."""
    alpha1: float = 0.05
    """Rotation noise from rotation (variance factor, rad^2/rad^2)."""
    alpha2: float = 0.001
    """Rotation noise from translation (rad^2/m^2)."""
    alpha3: float = 0.05
    """Translation noise from translation (m^2/m^2)."""
    alpha4: float = 0.01
    """Translation noise from rotation (m^2/rad^2)."""
    rotation_variance_per_radian: float = 0.0
    """Random-walk heading noise from rotation (rad^2 per rad turned): added to the variance of
    each rotation of a step in proportion to its size. Unlike the alphas (variance growing with
    the square of the step), it adds up to the same total however the odometry is divided into
    steps, i.e. however often observations arrive. 0 (default): alphas only."""
    rotation_variance_per_meter: float = 0.0
    """Random-walk heading noise from translation (rad^2 per m travelled), split between the two
    rotations of a step."""
    translation_variance_per_meter: float = 0.0
    """Random-walk translation noise from translation (m^2 per m travelled)."""
    translation_variance_per_radian: float = 0.0
    """Random-walk translation noise from rotation (m^2 per rad turned)."""
    min_translation_sigma: float = 0.001
    """Noise floor added to every motion step's translation (m), so P never collapses."""
    min_rotation_sigma: float = 0.001
    """Noise floor added to every motion step's rotations (rad)."""
    max_pending_translation: float = 1.0
    """Odometry accumulated beyond this distance (m) is applied without waiting for an
    observation, so one (rot1, trans, rot2) step never spans a long curve."""
    max_pending_rotation: float = 0.5
    """Same bound for accumulated rotation (rad)."""
    max_prior_heading_sigma: float = 0.3
    """FastSLAM 2.0: odometry between observations is carried as one Gaussian per particle, so
    the proposal sees all of its uncertainty; once its heading standard deviation exceeds this
    (rad) the particles are sampled from it, before linearisation fails."""
    proposal_iterations: int = 1
    """FastSLAM 2.0: linearisations of the proposal per reading. 1: Jacobians at the predicted
    pose; more: re-taken at the refined mean (Gauss-Newton), for wide priors."""
    association_passes: int = 1
    """FastSLAM 2.0: 1 associates every observation at the predicted pose; 2 associates again
    at the mean of the proposal that the first associations give (the robot's pose corrected
    by this reading's confident matches), then recomputes the proposal."""
    sigma_range: float = 0.1
    """Range measurement standard deviation (m)."""
    sigma_bearing: float = 0.0175
    """Bearing measurement standard deviation (rad)."""
    sigma_range_per_meter: float = 0.0
    """Range noise that grows with the range (m per m): the range variance of an observation
    is sigma_range^2 + (sigma_range_per_meter * range)^2 (camera ranges from apparent size)."""
    outlier_probability: float = 0.0
    """eps: probability that an observation associated with a landmark is an outlier, uniform
    over the perceptual range (min_range..max_range, field_of_view). Its likelihood is
    (1 - eps) N(z; z_hat, L) + eps / (range span * field_of_view), so one outlier cannot wipe
    out the good particles; an observation whose outlier term is the larger one is not used for
    the pose proposal nor the landmark update (``association.reject_outliers``). 0 (default):
    plain Gaussian."""
    sensor_x: float = 0.0
    """Sensor position on the robot, forward (m)."""
    sensor_y: float = 0.0
    """Sensor position on the robot, left (m)."""
    sensor_yaw: float = 0.0
    """Sensor heading relative to the robot (rad)."""
    min_range: float = 0.0
    """Perceptual range, near bound (m): closer landmarks get no negative evidence."""
    max_range: float = 30.0
    """Perceptual range, far bound (m)."""
    field_of_view: float = 2.0 * math.pi
    """Full opening angle of the sensor (rad), centred on its x axis."""
    logodds_observed: float = 1.0
    """tau+: log-odds added when a landmark is observed (and given to a new landmark)."""
    logodds_missed: float = -0.5
    """tau-: log-odds added when a landmark inside the perceptual range is not observed."""
    logodds_remove: float = -1.5
    """A landmark whose log-odds fall below this bound is removed."""
    logodds_max: float = 10.0
    """Log-odds saturate here, so a landmark that disappears can still be removed."""
    resampling: str = "systematic"
    """``systematic``, ``stratified``, ``residual`` or ``multinomial``."""
    resample_threshold: float = 0.5
    """Resample when N_eff < resample_threshold * M (1.0: every update)."""
    best_switch_margin: float = 0.0
    """The particle reported as the best (its pose, map and path) is replaced only by one whose
    log weight exceeds its own by more than this (nats); 0: always the highest weight. Particles
    whose whole map and path are turned against each other (a freedom the observations do not
    fix) weigh about the same, and without a margin the outputs can flip between them from one
    reading to the next."""
    best_particle: str = "heaviest"
    """Which particle is reported (its pose, map and path): ``heaviest``, the highest weight
    (with ``best_switch_margin``), or ``central`` (margin 0), the one nearest the weighted mean
    position, i.e. the particle with the least expected squared position error under the
    particle posterior. When particles with turned maps weigh about the same, the heaviest one
    can sit at either end of the spread; the central one sits where most of the weight is."""
    cell_size: float = 10.0
    """Side (m) of the spatial cells that index each particle's map."""
    seed: int = -1
    """Seed of the random generator; -1 draws one from the OS."""
    backend: str = "auto"
    """Per-reading math: ``numpy`` (the reference), ``numba`` (compiled, parallel over
    particles; the same results; needs the ``fast`` extra) or ``auto`` (numba when installed)."""

    def validate(self) -> "FastSLAMConfig":
        """Raise ``ValueError`` naming the first bad field; return self when all are good."""
        def need(ok: bool, field: str, rule: str) -> None:
            if not ok:
                raise ValueError(f"{field}: must be {rule} (got {getattr(self, field)!r})")

        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if isinstance(value, float):
                need(math.isfinite(value), field.name, "finite")
        need(isinstance(self.num_particles, int) and self.num_particles >= 1, "num_particles", ">= 1")
        need(self.algorithm in ALGORITHMS, "algorithm", f"one of {ALGORITHMS}")
        need(self.association in ASSOCIATION_MODES, "association", f"one of {ASSOCIATION_MODES}")
        need(self.resampling in RESAMPLING_SCHEMES, "resampling", f"one of {RESAMPLING_SCHEMES}")
        need(self.monte_carlo_weight in MONTE_CARLO_WEIGHTS, "monte_carlo_weight",
             f"one of {MONTE_CARLO_WEIGHTS}")
        need(self.new_landmark_likelihood > 0.0, "new_landmark_likelihood", "> 0")
        need(self.association_gate > 0.0, "association_gate", "> 0")
        need(self.new_landmark_gate >= self.association_gate, "new_landmark_gate",
             ">= association_gate")
        for name in ("alpha1", "alpha2", "alpha3", "alpha4", "rotation_variance_per_radian",
                     "rotation_variance_per_meter", "translation_variance_per_meter",
                     "translation_variance_per_radian"):
            need(getattr(self, name) >= 0.0, name, ">= 0")
        need(self.min_translation_sigma > 0.0, "min_translation_sigma", "> 0")
        need(self.min_rotation_sigma > 0.0, "min_rotation_sigma", "> 0")
        need(self.max_pending_translation > 0.0, "max_pending_translation", "> 0")
        need(self.max_pending_rotation > 0.0, "max_pending_rotation", "> 0")
        need(self.max_prior_heading_sigma > 0.0, "max_prior_heading_sigma", "> 0")
        need(isinstance(self.proposal_iterations, int) and 1 <= self.proposal_iterations <= 10,
             "proposal_iterations", "an integer in [1, 10]")
        need(isinstance(self.association_passes, int) and 1 <= self.association_passes <= 5,
             "association_passes", "an integer in [1, 5]")
        need(self.sigma_range > 0.0, "sigma_range", "> 0")
        need(self.sigma_bearing > 0.0, "sigma_bearing", "> 0")
        need(self.sigma_range_per_meter >= 0.0, "sigma_range_per_meter", ">= 0")
        need(0.0 <= self.outlier_probability < 1.0, "outlier_probability", "in [0, 1)")
        need(self.min_range >= 0.0, "min_range", ">= 0")
        need(self.max_range > self.min_range, "max_range", "> min_range")
        need(0.0 < self.field_of_view <= 2.0 * math.pi, "field_of_view", "in (0, 2 pi]")
        need(self.logodds_observed > 0.0, "logodds_observed", "> 0")
        need(self.logodds_missed <= 0.0, "logodds_missed", "<= 0")
        need(self.logodds_remove < self.logodds_observed, "logodds_remove", "< logodds_observed")
        need(self.logodds_max >= self.logodds_observed, "logodds_max", ">= logodds_observed")
        need(0.0 < self.resample_threshold <= 1.0, "resample_threshold", "in (0, 1]")
        need(self.best_switch_margin >= 0.0, "best_switch_margin", ">= 0")
        need(self.best_particle in BEST_PARTICLE_RULES, "best_particle",
             f"one of {BEST_PARTICLE_RULES}")
        need(self.best_particle == "heaviest" or self.best_switch_margin == 0.0,
             "best_switch_margin", "0 with best_particle central (the margin applies to heaviest)")
        need(self.cell_size > 0.0, "cell_size", "> 0")
        need(isinstance(self.seed, int) and self.seed >= -1, "seed", "an integer >= -1")
        need(self.backend in BACKENDS, "backend", f"one of {BACKENDS}")
        need(self.backend != "numba" or numba_available(), "backend",
             "numpy or auto when numba is not installed (pip install numba)")
        return self

    def replace(self, **changes) -> "FastSLAMConfig":
        """A validated copy with some fields changed."""
        return dataclasses.replace(self, **changes).validate()


def numba_available() -> bool:
    """numba can be imported (the compiled backend's optional dependency)."""
    try:
        import numba  # noqa: F401, PLC0415
    except ImportError:
        return False
    return True
