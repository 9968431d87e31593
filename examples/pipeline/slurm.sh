#!/bin/bash
# A Slurm array job that bakes a manifest's jobs in 8 shards. Submit from the folder that
# holds the manifest's path (a task starts in the folder it was submitted from), with any
# #SBATCH line overridden on the command line to fit the cluster, say:
#   sbatch examples/pipeline/slurm.sh
#   sbatch --array=0-1 --cpus-per-task=1 --mem=1G --wait examples/pipeline/slurm.sh
# Task I of an array of N runs --shard I/N (by cost: the greatest inputs first onto the
# least-loaded shard, the same split on every node). Together the tasks run every job once;
# each keeps its own state file (assets.shard-I-of-N.state.json) beside the manifest, so a
# resubmission reruns only what changed. The folder must be on a file system all nodes share.
# Settings from the environment (sbatch passes it on), with their defaults:
#   MANIFEST=examples/pipeline/assets.toml  the manifest
#   CUBEFORGE=cubeforge                      the program (found on PATH)
#   CUBEFORGE_CACHE=                         a team cache's URL: shards share what any built
# --array from 0 with no step: the task ids are the shard indexes.
#SBATCH --job-name=cubeforge-bake
#SBATCH --array=0-7
#SBATCH --cpus-per-task=8
#SBATCH --mem=16G
#SBATCH --time=01:00:00
#SBATCH --output=bake-%A_%a.log

set -euo pipefail
MANIFEST="${MANIFEST:-examples/pipeline/assets.toml}"
CUBEFORGE="${CUBEFORGE:-cubeforge}"
# One thread per CPU Slurm gave this task; --max-memory 7/8 of its --mem (MiB).
export RAYON_NUM_THREADS="${SLURM_CPUS_PER_TASK:-1}"
memory=()
if [ -n "${SLURM_MEM_PER_NODE:-}" ]; then
    memory=(--max-memory "$((SLURM_MEM_PER_NODE * 7 / 8))M")
fi
exec "$CUBEFORGE" batch "$MANIFEST" \
    --shard "${SLURM_ARRAY_TASK_ID}/${SLURM_ARRAY_TASK_COUNT}" "${memory[@]}"
