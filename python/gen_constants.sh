#!/bin/sh
# Writes the trioct package's _constants.py from the C headers, so that the Python side
# has the same status table, caps and version as the library it loads, and nothing is
# typed twice:
#   python/gen_constants.sh common/trioct_status.h common/trioct_limits.h common/trioct_version.h > OUT
set -eu
status=$1
limits=$2
version=$3
echo '"""Generated at build time from trioct_status.h, trioct_limits.h and trioct_version.h by'
echo 'python/gen_constants.sh; do not edit."""'
echo
printf 'VERSION = %s\n' "$(sed -n 's/^#define TRIOCT_VERSION \("[^"]*"\).*/\1/p' "$version")"
echo
echo '# (code, name without the TRIOCT_ prefix, text), as in TRIOCT_STATUS_MAP.'
echo 'STATUS = ('
sed -n 's/^ *X(TRIOCT_\([A-Z0-9_]*\), *\([0-9][0-9]*\), *\("[^"]*"\)).*/    (\2, "\1", \3),/p' "$status"
echo ')'
echo
echo 'LIMITS = {'
sed -n 's/^#define \(TRIOCT_MAX_[A-Z0-9_]*\) \([0-9][0-9]*\).*/    "\1": \2,/p' "$limits"
echo '}'
