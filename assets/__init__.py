"""Data files of sphere_env (robot URDF, friction presets, shell calibration, log manifests).

Installed as the package ``sphere_env.assets``; load files with :func:`sphere_env.resources.asset_path`.
"""
