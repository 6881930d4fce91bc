# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Settings of the people tracker: one ``parameter(...)`` per field (default, range, meaning).

The node declares one ROS parameter per field, the YAML file and the docs table come from the
same metadata (``fastslam_ros.core.params.specs``), and ``validate()`` fails naming the field.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from fastslam_ros.core.existence import LOGODDS_MAX
from fastslam_ros.core.params import check_fields, parameter
from fastslam_ros.people.detection import MIXED_PIXEL_EDGES, MIXED_PIXEL_SHARE

INF = math.inf


@dataclass(frozen=True)
class TrackerSettings:
    """Every tunable of the conditional particle filter (SI units, radians)."""

    num_particles: int = parameter(200, "M, robot pose particles once localized.", low=1)
    global_particles: int = parameter(
        20000, "Robot pose particles while the pose is unknown (global localization over the "
               "free space, people not tracked); reduced to num_particles once their spread "
               "stays below converged_spread.", low=1)
    converged_spread: float = parameter(
        0.5, "Position standard deviation (m) of the particles below which global "
             "localization has converged.", low=0.0, low_exclusive=True)
    people_particles: int = parameter(50, "M_p, position particles per person and robot "
                                          "particle.", low=1)
    max_people: int = parameter(12, "Person slots per robot particle; a detection finding no "
                                    "free slot is left unexplained.", low=1)
    seed: int = parameter(-1, "Seed of the random generator (-1: from the OS).", low=-1)
    alpha1: float = parameter(0.05, "Motion noise: rotation from rotation (rad^2/rad^2).",
                              low=0.0)
    alpha2: float = parameter(0.01, "Motion noise: rotation from translation (rad^2/m^2).",
                              low=0.0)
    alpha3: float = parameter(0.05, "Motion noise: translation from translation (m^2/m^2).",
                              low=0.0)
    alpha4: float = parameter(0.01, "Motion noise: translation from rotation (m^2/rad^2).",
                              low=0.0)
    min_translation_sigma: float = parameter(
        0.005, "Noise floor of every motion step's translation (m).", low=0.0,
        low_exclusive=True)
    min_rotation_sigma: float = parameter(
        0.005, "Noise floor of every motion step's rotations (rad).", low=0.0,
        low_exclusive=True)
    sigma_hit: float = parameter(0.1, "Likelihood field: standard deviation (m) of a beam "
                                      "end's distance to the nearest obstacle.",
                                 low=0.0, low_exclusive=True)
    z_hit: float = parameter(0.9, "Likelihood field: weight of the map-explained component "
                                  "(the rest is uniform over the range).", low=0.0, high=1.0,
                             low_exclusive=True)
    beam_stride: int = parameter(6, "Every n-th beam weighs the robot particles (beams are "
                                    "correlated; AMCL uses about 60).", low=1)
    max_range: float = parameter(12.0, "Beams at or beyond this range (or the scan's "
                                       "range_max) are no return (m).", low=0.0,
                                 low_exclusive=True)
    min_range: float = parameter(0.1, "Beams below this range are ignored (m).", low=0.0)
    likelihood_max_distance: float = parameter(
        1.0, "Distance (m) at which the likelihood field is clipped.", low=0.0,
        low_exclusive=True)
    resample_threshold: float = parameter(
        0.5, "Resample the robot particles when N_eff / M falls below this.", low=0.0,
        high=1.0)
    sensor_x: float = parameter(0.0, "Laser position in the base frame, x (m).")
    sensor_y: float = parameter(0.0, "Laser position in the base frame, y (m).")
    sensor_yaw: float = parameter(0.0, "Laser yaw in the base frame (rad).", low=-math.pi,
                                  high=math.pi)
    person_motion: str = parameter(
        "brownian", "How a person moves between readings: 'brownian' (random steps, "
                    "person_diffusion) or 'constant_velocity' (each particle carries a "
                    "velocity: random acceleration person_acceleration, decaying with "
                    "person_velocity_time, capped at max_person_speed, plus steps of "
                    "person_sway).",
        choices=("brownian", "constant_velocity"))
    person_diffusion: float = parameter(
        0.4, "Brownian motion of a person: sigma = person_diffusion * sqrt(dt) per axis "
             "(m/sqrt(s)).", low=0.0, low_exclusive=True)
    person_sway: float = parameter(
        0.2, "constant_velocity: Brownian steps on top of a person's velocity, sigma = "
             "person_sway * sqrt(dt) per axis (m/sqrt(s)).", low=0.0)
    person_acceleration: float = parameter(
        0.6, "constant_velocity: white-noise acceleration of a person per axis: over dt its "
             "velocity changes by N(0, person_acceleration^2 dt) (m/s^1.5).", low=0.0)
    person_velocity_time: float = parameter(
        2.0, "constant_velocity: time constant (s) of a person's velocity decaying towards "
             "rest (a person unseen for long is predicted to stop, not to walk on); brownian: "
             "of an undetected person's person_walk_time velocity.",
        low=0.0, low_exclusive=True)
    person_walk_time: float = parameter(
        1.0, "brownian: time constant (s) over which a person's walking velocity is smoothed "
             "from its detections (its mean's displacement between two); its particles drift "
             "with it, and walk on at it, slowing with person_velocity_time, while it is not "
             "detected (a person hidden for a moment is looked for where it walked to); 0: "
             "off.", low=0.0)
    detection_sigma: float = parameter(0.1, "Standard deviation of a person detection per "
                                            "axis (m).", low=0.0, low_exclusive=True)
    person_radius: float = parameter(0.2, "Radius of a person's outline in the scan (m): a "
                                          "detection is the nearest beam end pushed this far.",
                                     low=0.0)
    min_obstacle_distance: float = parameter(
        0.3, "A beam ending at least this far (m) from every mapped obstacle may hit a person.",
        low=0.0, low_exclusive=True)
    short_margin: float = parameter(
        0.15, "A beam ending in free space nearer than min_obstacle_distance to a mapped "
             "obstacle is still dynamic when the map has no obstacle within this distance (m) "
             "beyond its end along the beam (the beam ended clearly short of the map's "
             "expected range: a person beside a wall or a table); 0: off.", low=0.0)
    segment_jump: float = parameter(
        0.3, "Neighbouring beams whose ranges differ by more than this (m) belong to different "
             "objects.", low=0.0, low_exclusive=True)
    min_detection_beams: int = parameter(
        2, "Beams a person must return to be detected ('legs', mixed pixels not filtered: "
           "farther than one leg returns this many, the beams one leg returns there, at least "
           "one, unless a leg is partly hidden); beyond the range at which a person returns "
           "this many, not detecting one is no evidence of absence.",
        low=1)
    max_person_width: float = parameter(1.0, "Wider free-space segments are not one person (m).",
                                        low=0.0, low_exclusive=True)
    new_person_likelihood: float = parameter(
        0.02, "p0 (1/m^2): a detection less likely than this under every person starts a new "
              "one, and weighs its robot particle by p0.", low=0.0, low_exclusive=True)
    logodds_observed: float = parameter(1.0, "tau+: existence log-odds added when a person is "
                                             "detected (a new person starts at it).",
                                        low=0.0, low_exclusive=True)
    logodds_missed: float = parameter(-1.5, "tau-: added when a person in view and not occluded "
                                            "is not detected.", high=0.0)
    logodds_remove: float = parameter(-1.0, "A person whose log-odds fall below this is "
                                            "removed.")
    logodds_confirm: float = parameter(
        1.5, "A new person is tentative (not published) until its log-odds reach this: 1.5 "
             "is two detections at the default tau+ (log-odds saturate at 3).",
        high=LOGODDS_MAX)
    max_person_speed: float = parameter(
        1.5, "Fastest walking speed (m/s): constant_velocity caps the people's velocities at "
             "it; re-identification: a new person within this speed times the time unseen "
             "(plus a margin) of a hidden or removed person's last position takes its id.",
        low=0.0)
    lost_spread: float = parameter(
        1.0, "A person whose particles' position standard deviation (m, per axis) exceeds "
             "this is lost and removed (unseen for long, its Brownian cloud would catch "
             "other people's detections).", low=0.0, low_exclusive=True)
    max_map_cells: int = parameter(
        4_000_000, "A map with more cells (width x height) is dropped unread (a 2000 x 2000 "
                   "map, 100 m x 100 m at 0.05 m, takes about 0.5 s to install).", low=1)
    max_beams_per_scan: int = parameter(
        2048, "A scan with more beams is dropped unread (a tracked reading's time and memory grow "
              "with the beams).", low=1)
    person_model: str = parameter(
        "legs", "How a person looks in the scan: 'legs' (clusters of leg size paired into a "
                "person at the midpoint of the legs' centres, one leg alone still a person) or "
                "'blob' (one segment per person, its nearest beam end plus person_radius).",
        choices=("legs", "blob"))
    leg_radius: float = parameter(
        0.06, "Radius of a leg at the laser's height (m): a leg's centre is the mean of its "
              "cluster's beam ends pushed back pi/4 of this along the beam (the mean depth "
              "of a circle's front arc).", low=0.0)
    max_leg_width: float = parameter(
        0.25, "Clusters up to this wide (m, first to last beam end) are one leg; wider ones, "
              "up to max_person_width, are a person whose legs are seen as one.",
        low=0.0, low_exclusive=True)
    max_leg_spacing: float = parameter(
        0.5, "Two legs whose centres are at most this far apart (m) are one person's.",
        low=0.0)
    confirm_pairs: bool = parameter(
        True, "A new person seen as two legs apart is confirmed (published) at its first "
              "detection; one leg alone, or legs seen as one, at logodds_confirm.")
    confirm_far: bool = parameter(
        True, "A new person farther than the range within which one leg always returns a "
              "beam (2 leg_radius over the scan's angle increment: 6.9 m at 1 degree), where "
              "the beam spacing misses it in some scans, is confirmed (published) at its first "
              "detection (not while mixed pixels are filtered).")
    confirm_clear: bool = parameter(
        True, "A new person detected farther than max_leg_spacing from every mapped obstacle "
               "(open floor: no wall or furniture leg within a leg's spacing of it) is confirmed "
               "(published) at its first detection (not while mixed pixels are filtered).")
    mixed_pixel_filter: str = parameter(
        "auto", "A lone return between a nearer and a farther neighbour (each more than "
                "segment_jump away) is a mixed pixel, not dynamic, unless its nearer neighbour "
                "is dynamic and it lies within max_leg_spacing behind it or where a leg returns "
                "one beam: 'always' for lasers that return ranges between an object's silhouette "
                "and the background (it also hides a few people partly hidden behind "
                "furniture), 'never', or 'auto': on while over "
                f"{MIXED_PIXEL_SHARE:.0%} of the depth edges between mapped objects seen so far "
                f"(and until {MIXED_PIXEL_EDGES} were seen) were bridged by such a return, as "
                "they are for a laser that returns mixed pixels.",
        choices=("auto", "always", "never"))
    publish_spread: float = parameter(
        0.3, "A confirmed person whose particles' position standard deviation (m, per axis) "
             "exceeds this is tracked but not published (unseen for a while, its position is "
             "too uncertain to report).", low=0.0, low_exclusive=True)
    publish_hidden: bool = parameter(
        False, "Publish a confirmed person not detected in the scan whose beam ended more than "
               "person_radius short of it (hidden behind another person or an object); false "
               "keeps tracking it but leaves it out of ~/people until it is seen again, as "
               "annotations of what the laser sees count it.")

    def validate(self) -> "TrackerSettings":
        """Self when every field is in range (``ValueError`` naming the field otherwise)."""
        check_fields(self)
        if self.logodds_remove >= self.logodds_observed:
            raise ValueError("logodds_remove: must be < logodds_observed "
                             f"(got {self.logodds_remove!r})")
        if not self.logodds_remove < self.logodds_confirm:
            raise ValueError("logodds_confirm: must be > logodds_remove "
                             f"(got {self.logodds_confirm!r})")
        if self.min_range >= self.max_range:
            raise ValueError(f"min_range: must be < max_range (got {self.min_range!r})")
        return self
