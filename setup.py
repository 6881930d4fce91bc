"""ament_python package definition of fastslam_ros (also pip-installable)."""
from glob import glob

from setuptools import find_packages, setup

PACKAGE = "fastslam_ros"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", glob("config/*.yaml")),
        (f"share/{PACKAGE}/launch", glob("launch/*.launch.py")),
        (f"share/{PACKAGE}/rviz", glob("rviz/*.rviz")),
        (f"share/{PACKAGE}/foxglove", glob("foxglove/*.json")),
    ],
    python_requires=">=3.10",
    install_requires=["setuptools", "numpy>=1.24", "rosbags>=0.10", "matplotlib>=3.6",
                      "scipy>=1.10", "pyyaml>=5", "Pillow>=9", "threadpoolctl>=3"],
    extras_require={
        # A full ROS 2 Jazzy install provides these; in a plain venv they come from PyPI wheels.
        "ros": ["ros-jazzy-rclpy[fastrtps]", "ros-jazzy-common-interfaces"],
        "test": ["pytest>=7", "pytest-timeout>=2", "hypothesis>=6", "ruff>=0.5"],
        # The compiled backend of the core (``backend: auto`` uses it when installed).
        "fast": ["numba>=0.59"],
    },
    zip_safe=True,
    maintainer="fastslam_ros maintainers",
    maintainer_email="fastslam-ros@users.noreply.github.com",
    description="FastSLAM 1.0 / 2.0 landmark SLAM for ROS 2 Jazzy, with a numpy core.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "fastslam_node = fastslam_ros.node:main",
            "people_tracker_node = fastslam_ros.people_node:main",
            "landmark_extractor_node = fastslam_ros.landmark_extractor_node:main",
            "fastslam-sim = fastslam_ros.tools.simulation.sim:main",
            "fastslam-replay = fastslam_ros.tools.bags.replay:main",
            "fastslam-play = fastslam_ros.tools.bags.play:main",
            "fastslam-eval = fastslam_ros.tools.evaluation.evaluate:main",
            "fastslam-demo = fastslam_ros.tools.demo:main",
            "fastslam-convert = fastslam_ros.tools.datasets.convert:main",
            "fastslam-benchmark = fastslam_ros.tools.benchmarks.benchmark:main",
            "fastslam-bench = fastslam_ros.tools.benchmarks.bench:main",
            "fastslam-poison = fastslam_ros.tools.bags.poison:main",
            "fastslam-calibrate = fastslam_ros.tools.evaluation.calibrate:main",
        ],
    },
)
