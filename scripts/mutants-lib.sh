# Shared by the mutation scripts (mutants-score, mutants-diff, mutants-exclusions); sourced,
# not run.

# The flight crates whose mutants are judged (docs/verification.md).
FLIGHT_CRATES=(heli-proto heli-nav heli-control heli-fsw heli-vehicle)

# Makes sure cargo-mutants is there: installs the version the figures were measured with
# when MUTANTS_INSTALL=1, otherwise says how and exits 2. $1 names the calling script.
mutants_require() {
  if command -v cargo-mutants >/dev/null 2>&1; then
    return 0
  fi
  if [ "${MUTANTS_INSTALL:-0}" = 1 ]; then
    cargo install --locked --quiet cargo-mutants@27.1.0
  else
    echo "$1: cargo-mutants is not installed (cargo install --locked cargo-mutants@27.1.0)" >&2
    exit 2
  fi
}

# The test tool's arguments, in MUTANTS_TOOL: a crate's tests run in parallel under nextest
# where it is installed (the vehicle's take seconds each), under cargo test otherwise.
MUTANTS_TOOL=()
if cargo nextest --version >/dev/null 2>&1; then
  MUTANTS_TOOL=(--test-tool nextest)
fi
