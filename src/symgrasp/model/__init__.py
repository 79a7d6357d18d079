"""The volumetric grasp detector, its loss, metrics, checkpoints and training loop.

- `network`: `GraspNet` (3D encoder–decoder + score, validity and rotation heads),
  `NetworkConfig`, `count_parameters`, `count_flops`;
- `loss`: `grasp_losses` (validity BCE or focal + score L2 + the representation's rotation
  loss);
- `metrics`: validity AP, score MAE, rotation errors up to the flip, Bingham confidence, the
  top-k metrics of the voxels the detector would pick (`ranking.rank_voxels`);
- `checkpoint`: `save_checkpoint`, `load_checkpoint`, `load_model`, `trained_gripper`;
- `schedule`: `learning_rate`, the lr of every optimizer step;
- `averaging`: `WeightAverage`, the exponential moving average of the weights;
- `train`: `TrainConfig` and `train`, what ``symgrasp train`` runs;
- `synthetic`: analytic box scenes that follow the dataset contract, for tests and benchmarks.

See ``docs/model.md``.
"""

from symgrasp.config import LossWeights, NetworkConfig, TrainConfig
from symgrasp.model.checkpoint import load_checkpoint, load_model, save_checkpoint
from symgrasp.model.loss import grasp_losses
from symgrasp.model.network import (
    GraspNet,
    GraspOutput,
    count_flops,
    count_parameters,
)
from symgrasp.model.train import train

__all__ = [
    "GraspNet",
    "GraspOutput",
    "LossWeights",
    "NetworkConfig",
    "TrainConfig",
    "count_flops",
    "count_parameters",
    "grasp_losses",
    "load_checkpoint",
    "load_model",
    "save_checkpoint",
    "train",
]
