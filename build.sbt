// Streaming iELAS stereo accelerator generator.
ThisBuild / scalaVersion := "2.13.15"
ThisBuild / version      := "0.1.0"
ThisBuild / organization := "io.github.ielas"

val chiselVersion = "6.7.0"

lazy val root = (project in file("."))
  .settings(
    name := "ielas",
    libraryDependencies ++= Seq(
      "org.chipsalliance" %% "chisel"     % chiselVersion,
      "edu.berkeley.cs"   %% "chiseltest" % "6.0.0" % Test,
      "org.scalatest"     %% "scalatest"  % "3.2.19" % Test
    ),
    scalacOptions ++= Seq("-language:reflectiveCalls", "-deprecation", "-feature", "-Xcheckinit", "-Ymacro-annotations"),
    addCompilerPlugin("org.chipsalliance" % "chisel-plugin" % chiselVersion cross CrossVersion.full),
    Compile / run / mainClass := Some("ielas.Main"),
    Compile / run / fork := true,
    // Forked programs print straight to stdout (no "[info] " prefix), so report lines start their own line.
    outputStrategy := Some(StdoutOutput),
    Test / fork := true,
    Test / parallelExecution := false,
    Test / javaOptions ++= Seq("-Xss8m", "-Xmx4g"),
    // forward -Dielas.* (seed, vcd, golden, data) from the sbt command line into the forked test JVM
    Test / javaOptions ++= sys.props.toSeq.collect { case (k, v) if k.startsWith("ielas.") => s"-D$k=$v" },
    Test / baseDirectory := (ThisBuild / baseDirectory).value,
    Compile / run / baseDirectory := (ThisBuild / baseDirectory).value,
    Test / testOptions += Tests.Argument(TestFrameworks.ScalaTest, "-oD")
  )
