#!/bin/bash
# TEMPLATE: a Slurm array job that bakes the manifest's jobs on 8 nodes at once. Adapt the
# #SBATCH lines and the manifest's path, then submit from the repository's root (a task starts
# in the folder it was submitted from):  sbatch examples/pipeline/slurm.sh
# Task I of the array runs --shard I/8: the inputs k with k mod 8 = I. Together the 8 tasks
# run every job once; each keeps its own state file (assets.shard-I-of-8.state.json) beside
# the manifest, so a resubmission reruns only what changed. The folder must be on a file
# system all nodes share, and cubeforge on their PATH.
# --array from 0 with no step: the task ids are the shard indexes.
#SBATCH --job-name=cubeforge-bake
#SBATCH --array=0-7
#SBATCH --cpus-per-task=8
#SBATCH --mem=16G
#SBATCH --time=01:00:00
#SBATCH --output=bake-%A_%a.log

set -euo pipefail
# One thread per CPU Slurm gave this task; --max-memory a little under --mem.
export RAYON_NUM_THREADS="${SLURM_CPUS_PER_TASK}"
cubeforge batch examples/pipeline/assets.toml \
    --shard "${SLURM_ARRAY_TASK_ID}/${SLURM_ARRAY_TASK_COUNT}" --max-memory 14G
