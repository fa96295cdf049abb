"""Build script of the fishtail_design ament_python package (built by colcon)."""

from setuptools import find_packages, setup

PACKAGE = "fishtail_design"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="fishtail maintainers",
    maintainer_email="fishtail@example.com",
    description="Synthesis of the tail drive: linkage, gear ratio and operating point for a fish.",
    license="Apache-2.0",
    tests_require=["pytest"],
    entry_points={
        "console_scripts": [
            "fishtail-design = fishtail_design.cli:main",
        ],
    },
)
