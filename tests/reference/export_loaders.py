"""Load octavar's IMU noise exports with each target's own loader, and print what the loaders read, as JSON.

The loaders are the ones the targets use, from PyPI: PyYAML for Kalibr's imu.yaml and KF-GINS's config (Kalibr
reads its YAML with PyYAML; KF-GINS with yaml-cpp), OpenCV's FileStorage for OpenVINS, VINS and ORB-SLAM3 (all
three read their settings through cv::FileStorage, and ORB-SLAM3 refuses a figure that is not a real number),
GTSAM's own PreintegrationCombinedParams for the GTSAM file, and the standard library's XML parser for the SDF
fragment. MATLAB's script has no loader off MATLAB and is not read here.

usage: export_loaders.py DIR   (DIR holds kalibr.yaml, openvins.yaml, vins.yaml, orbslam3.yaml, gtsam.yaml,
kfgins.yaml, gz.sdf)
"""

import json
import os
import sys
import xml.etree.ElementTree as ET

import cv2
import gtsam
import numpy as np
import yaml


def opencv(path, keys, node=None):
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    if not fs.isOpened():
        raise SystemExit(f"OpenCV cannot open {path}")
    root = fs.getNode(node) if node else fs.root()
    out = {}
    for k in keys:
        n = root.getNode(k)
        if n.empty():
            raise SystemExit(f"{path}: OpenCV finds no {k}")
        if not n.isReal():
            raise SystemExit(f"{path}: OpenCV reads {k} as type {n.type()}, not a real number")
        out[k] = n.real()
    fs.release()
    return out


def main(d):
    out = {}
    with open(os.path.join(d, "kalibr.yaml")) as f:
        k = yaml.safe_load(f)
    for key in ("gyroscope_noise_density", "gyroscope_random_walk", "accelerometer_noise_density",
                "accelerometer_random_walk", "update_rate"):
        if not isinstance(k[key], float):
            raise SystemExit(f"kalibr.yaml: PyYAML reads {key} as {type(k[key]).__name__}")
    out["kalibr"] = k

    noise = ["accelerometer_noise_density", "accelerometer_random_walk", "gyroscope_noise_density",
             "gyroscope_random_walk", "update_rate"]
    out["openvins"] = opencv(os.path.join(d, "openvins.yaml"), noise, node="imu0")
    fs = cv2.FileStorage(os.path.join(d, "openvins.yaml"), cv2.FILE_STORAGE_READ)
    t = fs.getNode("imu0").getNode("T_i_b")
    out["openvins"]["T_i_b_rows"] = t.size()
    fs.release()

    out["vins"] = opencv(os.path.join(d, "vins.yaml"), ["acc_n", "gyr_n", "acc_w", "gyr_w", "g_norm"])
    out["orbslam3"] = opencv(os.path.join(d, "orbslam3.yaml"),
                             ["IMU.NoiseGyro", "IMU.NoiseAcc", "IMU.GyroWalk", "IMU.AccWalk", "IMU.Frequency"])

    with open(os.path.join(d, "gtsam.yaml")) as f:
        c = yaml.safe_load(f)
    p = gtsam.PreintegrationCombinedParams.MakeSharedU(c["gravity"])
    p.setGyroscopeCovariance(np.array(c["gyroscopeCovariance"], dtype=float))
    p.setAccelerometerCovariance(np.array(c["accelerometerCovariance"], dtype=float))
    p.setIntegrationCovariance(np.array(c["integrationCovariance"], dtype=float))
    p.setBiasOmegaCovariance(np.array(c["biasOmegaCovariance"], dtype=float))
    p.setBiasAccCovariance(np.array(c["biasAccCovariance"], dtype=float))
    out["gtsam"] = {
        "gyroscopeCovariance": np.asarray(p.getGyroscopeCovariance()).tolist(),
        "accelerometerCovariance": np.asarray(p.getAccelerometerCovariance()).tolist(),
        "biasOmegaCovariance": np.asarray(p.getBiasOmegaCovariance()).tolist(),
        "biasAccCovariance": np.asarray(p.getBiasAccCovariance()).tolist(),
        "gravity": float(np.linalg.norm(np.asarray(p.n_gravity))),
    }

    with open(os.path.join(d, "kfgins.yaml")) as f:
        kf = yaml.safe_load(f)["imunoise"]
    out["kfgins"] = {k: [float(x) for x in v] if isinstance(v, list) else float(v) for k, v in kf.items()}

    root = ET.parse(os.path.join(d, "gz.sdf")).getroot()
    gz = {}
    for group in ("angular_velocity", "linear_acceleration"):
        for axis in ("x", "y", "z"):
            n = root.find(f"{group}/{axis}/noise")
            gz[f"{group}/{axis}"] = {c.tag: float(c.text) for c in n}
    out["gz"] = gz
    print(json.dumps(out))


if __name__ == "__main__":
    main(sys.argv[1])
