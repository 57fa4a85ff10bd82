"""Terrain vision: SFTA texture features, the KNN terrain classifier, the ground camera.

Submodules (imported explicitly, so that loading the camera model for a
configuration does not import scikit-learn):

- :mod:`terrain_odom.vision.sfta`: SFTA features (Chen et al. 2023, eq. 18-21);
- :mod:`terrain_odom.vision.features`: region and tile feature vectors (SFTA, colour);
- :mod:`terrain_odom.vision.classifier`: KNN classifier, tile voting, model as arrays;
- :mod:`terrain_odom.vision.dataset`: labelled image sets, parallel feature extraction;
- :mod:`terrain_odom.vision.tuning`: settings chosen by (nested) cross-validation;
- :mod:`terrain_odom.vision.frame_classifier`: one camera frame to one terrain label;
- :mod:`terrain_odom.vision.camera`: ground-plane camera and region of interest.

Pure: files (images, model files) are read and written by :mod:`terrain_odom.io`.
"""
