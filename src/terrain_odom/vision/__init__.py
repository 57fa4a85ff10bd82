"""Terrain vision: SFTA texture features, the KNN terrain classifier, the ground camera.

Submodules (imported explicitly, so that loading the camera model for a
configuration does not import scikit-learn):

- :mod:`terrain_odom.vision.sfta`: SFTA features (Chen et al. 2023, eq. 18-21);
- :mod:`terrain_odom.vision.classifier`: KNN classifier, tile voting, model files;
- :mod:`terrain_odom.vision.dataset`: labelled image folders, parallel extraction;
- :mod:`terrain_odom.vision.camera`: ground-plane camera and region of interest.
"""
