#!/usr/bin/env bash
# Runs the sbt version pinned in project/build.properties.
# Uses an `sbt` on PATH when there is one; otherwise a cached sbt-launch jar, fetched once from
# Maven Central with Maven (`mvn dependency:copy`). Needs a JDK (11+) in either case.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$here" # sbt works on the project in the current directory
version="$(sed -n 's/^sbt\.version *= *//p' "$here/project/build.properties" | tr -d '[:space:]')"
if [ -z "$version" ]; then
  echo "sbt: no sbt.version in project/build.properties" >&2; exit 2
fi
# Plain log lines when the output is not a terminal (CI logs, pipes).
plain=()
[ -t 1 ] || plain=(-Dsbt.log.noformat=true)
if command -v sbt >/dev/null 2>&1 && [ -z "${ORB_SBT_LAUNCHER:-}" ]; then
  exec sbt ${plain[@]+"${plain[@]}"} "$@"
fi
if ! command -v java >/dev/null 2>&1; then
  echo "sbt: no 'java' on PATH; install a JDK 11 or newer (Debian: apt-get install default-jdk-headless)" >&2; exit 2
fi
cache="${ORB_SBT_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/orb-sbt}"
jar="$cache/sbt-launch-$version.jar"
if [ ! -s "$jar" ]; then
  if ! command -v mvn >/dev/null 2>&1; then
    echo "sbt: neither 'sbt' nor 'mvn' is on PATH; install one (Debian: apt-get install maven) or put sbt-launch-$version.jar at $jar" >&2
    exit 2
  fi
  echo "sbt: fetching sbt-launch $version from Maven Central into $cache (once)" >&2
  mkdir -p "$cache"
  # Run Maven from the cache directory, so that no pom.xml around the caller interferes.
  (cd "$cache" && mvn -q -B dependency:copy "-Dartifact=org.scala-sbt:sbt-launch:$version" "-DoutputDirectory=$cache") >&2 || {
    echo "sbt: could not fetch org.scala-sbt:sbt-launch:$version with Maven" >&2; exit 2; }
fi
# Big Verilator models and image buffers want a roomy heap and stack.
exec java ${SBT_JAVA_OPTS:--Xms512m -Xmx6g -Xss8m} ${plain[@]+"${plain[@]}"} -jar "$jar" "$@"
