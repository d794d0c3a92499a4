#!/usr/bin/env bash
# sbt without an sbt install: fetches the launcher jar from Maven Central once, checks its sha1, runs it.
# The launcher then resolves sbt itself (version in project/build.properties) from Maven Central.
set -euo pipefail
LAUNCHER_VERSION=1.10.11
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cache="${SBT_LAUNCHER_CACHE:-$here/build/sbt-launcher}"
jar="$cache/sbt-launch-$LAUNCHER_VERSION.jar"
url="https://repo1.maven.org/maven2/org/scala-sbt/sbt-launch/$LAUNCHER_VERSION/sbt-launch-$LAUNCHER_VERSION.jar"
if [ ! -s "$jar" ]; then
  mkdir -p "$cache"
  echo "sbt: fetching launcher $LAUNCHER_VERSION from Maven Central" >&2
  curl -fsSL --retry 3 -o "$jar.part" "$url"
  want="$(curl -fsSL --retry 3 "$url.sha1" | cut -c1-40)"
  got="$(sha1sum "$jar.part" | cut -c1-40)"
  if [ "$want" != "$got" ]; then
    echo "sbt: launcher sha1 mismatch (expected $want, got $got)" >&2; rm -f "$jar.part"; exit 1
  fi
  mv "$jar.part" "$jar"
fi
args=()
for a in "$@"; do [ "$a" = "-batch" ] || args+=("$a"); done  # sbt is always batch here (no terminal)
exec java ${SBT_JAVA_OPTS:--Xms512m -Xmx4g -Xss8m -XX:ReservedCodeCacheSize=256m -XX:+UseParallelGC} \
  -Dsbt.supershell=false -Dsbt.server.autostart=false -Dsbt.log.noformat=true \
  ${SBT_USER_HOME:+-Duser.home=$SBT_USER_HOME} \
  -jar "$jar" ${args[@]+"${args[@]}"}
