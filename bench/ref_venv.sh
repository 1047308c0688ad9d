# The reference venv (.venv-ref) of the independent tools the tests and benches compare against: allantools and
# numpy (Allan deviations), nptdms (writes TDMS files as NI's tools do), mcap and mcap-ros2-support (write ROS 2
# bags), rosbags (writes ROS 1 bags and rosbag2 SQLite and MCAP bags), pandas (the CSV reader the ingest bench races), and the loaders the IMU noise exports must parse in:
# PyYAML (Kalibr, KF-GINS), OpenCV's FileStorage (OpenVINS, VINS, ORB-SLAM3) and GTSAM; and for the Python package
# (python/): maturin (builds it), pytest (its tests) and matplotlib (the worked example in docs/python.md). Sourced by
# .ci/run and the bench scripts from the repository root; made or completed here when a package is missing; sets
# PY to its python.
REF_PACKAGES="allantools==2024.6 numpy nptdms==1.13.0 mcap==1.6.0 mcap-ros2-support==0.6.0 rosbags==0.11.9 pandas gtsam==4.3.0 opencv-python-headless==5.0.0.93 pyyaml==6.0.4 maturin==1.16.0 pytest==9.2.0 matplotlib==3.11.2"
if [ ! -x .venv-ref/bin/python ]; then
    python3 -m venv .venv-ref
fi
if ! .venv-ref/bin/python -c "import allantools, numpy, nptdms, mcap, mcap_ros2, rosbags, pandas, yaml, cv2, gtsam, maturin, pytest, matplotlib" 2>/dev/null; then
    .venv-ref/bin/pip install --quiet $REF_PACKAGES
fi
PY=$PWD/.venv-ref/bin/python
