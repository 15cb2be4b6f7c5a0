// ORB feature extraction and matching core: SpinalHDL generator + golden model (root),
// host-side simulation tools and OpenCV comparison (sim/).
ThisBuild / scalaVersion := "2.13.16"
ThisBuild / organization := "orbcore"
ThisBuild / version := "0.1.0-SNAPSHOT"
ThisBuild / scalacOptions ++= Seq("-deprecation", "-feature", "-unchecked", "-language:reflectiveCalls")

val spinalVersion = "1.14.2"
val javacvVersion = "1.5.13"
// OpenCV's native libraries for this machine (JavaCV publishes one jar per platform).
val platform = sys.props("os.arch") match {
  case "aarch64" | "arm64" => "linux-arm64"
  case _ => "linux-x86_64"
}

lazy val spinalDeps = Seq(
  libraryDependencies ++= Seq(
    "com.github.spinalhdl" %% "spinalhdl-core" % spinalVersion,
    "com.github.spinalhdl" %% "spinalhdl-lib" % spinalVersion,
    compilerPlugin("com.github.spinalhdl" %% "spinalhdl-idsl-plugin" % spinalVersion),
    "org.scalatest" %% "scalatest" % "3.2.19" % Test
  )
)

// Every suite builds its Verilator model once; running suites one at a time keeps a 2-core machine responsive.
lazy val testSettings = Seq(
  // the formatting (.scalafmt.conf) is checked with the tests; `./sbt scalafmtAll` applies it
  Test / test := (Test / test).dependsOn(scalafmtCheckAll).value,
  Test / fork := true,
  Test / parallelExecution := false,
  Test / javaOptions ++= Seq("-Xmx6g", "-Xss16m"),
  Test / baseDirectory := (ThisBuild / baseDirectory).value,
  Test / testOptions += Tests.Argument(TestFrameworks.ScalaTest, "-oD"),
  run / fork := true,
  run / baseDirectory := (ThisBuild / baseDirectory).value,
  run / javaOptions ++= Seq("-Xmx6g", "-Xss16m"),
  run / connectInput := true
)

// `./sbt test` runs both projects' suites, one suite at a time; `runMain` stays with the generator.
Global / concurrentRestrictions += Tags.limit(Tags.Test, 1)

lazy val root: Project = (project in file("."))
  .aggregate(LocalProject("sim"))
  .settings(name := "orb-core", spinalDeps, testSettings,
    // The BRIEF test pattern is data (data/orb_pattern_31.csv) that the generator and the model both read.
    Compile / unmanagedResourceDirectories += baseDirectory.value / "data",
    Compile / unmanagedResources / includeFilter := "orb_pattern_31.csv" || "*.v" || "*.ys" || "*.py",
    Compile / run / aggregate := false,
    Compile / runMain / aggregate := false)

lazy val sim: Project = (project in file("sim"))
  .dependsOn(root % "compile->compile;test->test")
  .settings(
    name := "orb-sim",
    spinalDeps,
    testSettings,
    libraryDependencies ++= Seq(
      "org.bytedeco" % "javacv" % javacvVersion excludeAll (ExclusionRule("org.bytedeco", "ffmpeg"),
        ExclusionRule("org.bytedeco", "flycapture"), ExclusionRule("org.bytedeco", "libdc1394"),
        ExclusionRule("org.bytedeco", "libfreenect"), ExclusionRule("org.bytedeco", "libfreenect2"),
        ExclusionRule("org.bytedeco", "librealsense"), ExclusionRule("org.bytedeco", "librealsense2"),
        ExclusionRule("org.bytedeco", "videoinput"), ExclusionRule("org.bytedeco", "artoolkitplus"),
        ExclusionRule("org.bytedeco", "flandmark"), ExclusionRule("org.bytedeco", "leptonica"),
        ExclusionRule("org.bytedeco", "tesseract")),
      "org.bytedeco" % "opencv" % s"4.13.0-$javacvVersion",
      "org.bytedeco" % "opencv" % s"4.13.0-$javacvVersion" classifier platform,
      "org.bytedeco" % "openblas" % s"0.3.31-$javacvVersion",
      "org.bytedeco" % "openblas" % s"0.3.31-$javacvVersion" classifier platform,
      "org.bytedeco" % "javacpp" % javacvVersion,
      "org.bytedeco" % "javacpp" % javacvVersion classifier platform,
      // Figure 9 plots (orb.sim.Evaluate)
      "org.knowm.xchart" % "xchart" % "3.8.8"
    )
  )
