# Sourced by the scripts whose outputs the repository ships and the tests
# check to the bit (the bundled banks, the tables of docs/): glibc picks its
# math functions (exp, log, pow, sin, cos) by the CPU, and the FMA variants
# a newer x86-64 CPU gets round differently in the last bit from the
# baseline ones. A fit near a bound of its parameters turns that bit into a
# different sixth digit, so a bank regenerated on one machine differed from
# the same script's on another. These scripts ask glibc for its baseline
# variants on every CPU, so that they give the same bits everywhere; the
# tool itself, run by a user, takes the fastest.
#   source scripts/same_bits.sh
export GLIBC_TUNABLES="${GLIBC_TUNABLES:+$GLIBC_TUNABLES:}glibc.cpu.hwcaps=-AVX,-AVX2,-FMA,-FMA4,-AVX512F"
