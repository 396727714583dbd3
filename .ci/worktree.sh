# Sourced by the mutation scripts (.ci/wgsl-mutants.sh,
# .ci/cargo-mutants.sh) from the checkout's root with ROOT and WORK set:
# makes $WORK a detached worktree of HEAD (removed again on exit), so the
# checkout's files are never modified, makes $LOGS (default $WORK-logs)
# empty, and leaves the shell in $WORK.
rm -rf "$WORK"
git worktree prune
git worktree add --quiet --detach "$WORK" HEAD
trap 'git -C "$ROOT" worktree remove --force "$WORK" > /dev/null 2>&1 || true' EXIT
cd "$WORK"
LOGS=${LOGS:-$WORK-logs}
rm -rf "$LOGS"
mkdir -p "$LOGS"
