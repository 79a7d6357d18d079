"""Training data: per-object grasp databases, cluttered scenes with voxel labels, datasets.

Read in this order (docs/data.md): ``directions`` and ``grasp_db`` (settled grasps and their
gravity-rejection scores per object), ``collision`` and ``labels`` (which grasps survive in a
scene, and their 40³ voxel labels), ``scenes`` (one labelled scene as a pure task),
``generate`` (dataset folders), ``dataset`` (the torch ``GraspDataset`` and
``collate_scenes``), ``validate`` and ``card`` (physics check, dataset card, pictures).
"""
