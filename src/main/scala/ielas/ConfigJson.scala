package ielas

import java.nio.file.{Files, Path, Paths}
import java.nio.charset.StandardCharsets

/** Writes [[ElasParams]] as the configuration JSON the golden model reads, and reads such a file back.
  *
  * The format is one flat JSON object: integers, floats, strings, and integer arrays; booleans are 0/1 so that
  * OpenCV's `cv::FileStorage` reads every field. Keys are the case-class field names; derived values follow.
  */
object ConfigJson {
  private def b(x: Boolean): Int = if (x) 1 else 0

  def fields(p: ElasParams): Seq[(String, Any)] = Seq(
    "name" -> p.name,
    "maxWidth" -> p.maxWidth,
    "maxHeight" -> p.maxHeight,
    "dispMax" -> p.dispMax,
    "windowSize" -> p.windowSize,
    "storedDisparities" -> p.storedDisparities,
    "candidateStep" -> p.candidateStep,
    "gridSize" -> p.gridSize,
    "parameterSet" -> p.parameterSet.name,
    "supportTexture" -> p.supportTexture,
    "supportMinRange" -> p.supportMinRange,
    "inconWindowSize" -> p.inconWindowSize,
    "inconThreshold" -> p.inconThreshold,
    "inconMinSupport" -> p.inconMinSupport,
    "lrThreshold" -> p.lrThreshold,
    "beta" -> p.beta,
    "sigma" -> p.sigma,
    "speckleSimThreshold" -> p.speckleSimThreshold,
    "speckleSize" -> p.speckleSize,
    "speckleWindowRows" -> p.speckleWindowRows,
    "ipolColumnWindow" -> p.ipolColumnWindow,
    "fillRule" -> p.fillRule.name,
    "fillEpsilon" -> p.fillEpsilon,
    "sDelta" -> p.sDelta,
    "epsilon" -> p.epsilon,
    "fillC" -> p.fillC,
    "cyclesPerPixel" -> p.cyclesPerPixel,
    "supportLanes" -> p.supportLanes,
    "denseLanes" -> p.denseLanes,
    // derived (read-only for the golden model)
    "supportLanesUsed" -> p.supportLanesUsed,
    "denseLanesUsed" -> p.denseLanesUsed,
    "supportThresholdPercent" -> p.supportThresholdPercent,
    "gamma" -> p.gamma,
    "sradius" -> p.sradius,
    "planeRadius" -> p.planeRadius,
    "matchTexture" -> p.matchTexture,
    "addCorners" -> b(p.addCorners),
    "ipolGapWidth" -> p.ipolGapWidth,
    "filterMedian" -> b(p.filterMedian),
    "filterAdaptiveMean" -> b(p.filterAdaptiveMean),
    "postprocessOnlyLeft" -> b(p.postprocessOnlyLeft),
    "descriptorBytes" -> p.descriptorBytes,
    "descriptorMargin" -> p.descriptorMargin,
    "supportMargin" -> p.supportMargin,
    "latticeColsMax" -> p.latticeColsMax,
    "latticeRowsMax" -> p.latticeRowsMax,
    "gridColsMax" -> p.gridColsMax,
    "gridRowsMax" -> p.gridRowsMax,
    "priorTable" -> p.priorTable,
    // the legal values of every card parameter (ElasParams.legal), which the golden model checks
    "legal" -> Raw(legalJson)
  )

  /** The text of a JSON value written as it is. */
  final case class Raw(text: String)

  /** The `"legal"` object: each card parameter's rules in [[ElasParams.legal]]'s order. */
  lazy val legalJson: String = {
    val params = ElasParams.legal.map(_.param).distinct
    params.map { k =>
      s"""    "$k": ${ElasParams.legal.filter(_.param == k).map(_.json).mkString("[", ", ", "]")}"""
    }.mkString("{\n", ",\n", "\n  }")
  }

  /** A preset file (golden/configs/presets/<set>.json): the configuration (SAD lanes automatic, as in every
    * preset) and the parameters that follow the size.
    */
  def presetJson(set: ParameterSet): String =
    renderObject(fields(ElasParams.presetBase(set)) :+
      ("presetFollows" -> Raw(ElasParams.presetFollows.map("\"" + _ + "\"").mkString("[", ", ", "]"))))

  private def render(v: Any): String = v match {
    case s: String  => "\"" + s + "\""
    case d: Double  => if (d == math.rint(d)) f"$d%.1f" else d.toString
    case i: Int     => i.toString
    case xs: Seq[_] => xs.map(render).mkString("[", ", ", "]")
    case Raw(text)  => text
    case other      => throw new IllegalArgumentException(s"ConfigJson: cannot render $other")
  }

  private def renderObject(fs: Seq[(String, Any)]): String =
    fs.map { case (k, v) => s"""  "$k": ${render(v)}""" }.mkString("{\n", ",\n", "\n}\n")

  def toJson(p: ElasParams): String = renderObject(fields(p))

  def write(p: ElasParams, dir: Path): Path = {
    Files.createDirectories(dir)
    val file = dir.resolve(s"${p.name}.json")
    Files.write(file, toJson(p).getBytes(StandardCharsets.UTF_8))
    file
  }

  /** DIR/presets/<set>.json for every parameter set. */
  def writePresets(dir: Path): Seq[Path] = ParameterSet.all.map { set =>
    val file = dir.resolve("presets").resolve(s"${set.name}.json")
    Files.createDirectories(file.getParent)
    Files.write(file, presetJson(set).getBytes(StandardCharsets.UTF_8))
    file
  }

  /** A configuration by name (one of [[ElasParams.named]]) or by JSON file path. */
  def load(nameOrFile: String): ElasParams =
    if (nameOrFile.endsWith(".json")) fromJson(new String(Files.readAllBytes(Paths.get(nameOrFile)), StandardCharsets.UTF_8), nameOrFile)
    else ElasParams.byName(nameOrFile)

  /** `NAME:BASE[:KEY=VALUE,...]`: the configuration BASE (a name or JSON file) renamed NAME, with constructor
    * fields overridden. The SAD lanes go back to BASE's own setting (0 = derived) unless overridden, so that they
    * follow a changed dispMax or storedDisparities. Unknown keys fail, naming the key.
    */
  def fromSpec(spec: String): ElasParams = {
    val parts = spec.split(":", 3)
    require(parts.length >= 2 && parts(0).nonEmpty && parts(1).nonEmpty, s"config spec '$spec': expected NAME:BASE[:KEY=VALUE,...]")
    val base = load(parts(1))
    val ctor = fields(base).map(_._1).takeWhile(_ != "supportThresholdPercent").toSet
    val overrides = (if (parts.length == 3) parts(2).split(",").toSeq.filter(_.nonEmpty) else Nil).map { kv =>
      val i = kv.indexOf('=')
      require(i > 0, s"config spec '$spec': '$kv' is not KEY=VALUE")
      val (k, v) = (kv.take(i), kv.drop(i + 1))
      require(ctor(k) && k != "name", s"config spec '$spec': unknown parameter '$k' (legal: ${(ctor - "name").toSeq.sorted.mkString(", ")})")
      k -> v
    }.toMap
    // Like the named presets, fillC follows dispMax (min(default, dispMax)) unless given.
    val fillC = overrides.get("dispMax").filter(_ => !overrides.contains("fillC") && base.fillC == math.min(ElasParams().fillC, base.dispMax))
      .flatMap(_.toIntOption).map(d => math.min(ElasParams().fillC, d)).getOrElse(base.fillC)
    val own = Map("name" -> parts(0), "fillC" -> fillC)
    val text = fields(base).filter(f => ctor(f._1)).map { case (k, v0) =>
      val v = own.getOrElse(k, v0)
      val r = overrides.get(k).map(x => if (x.toDoubleOption.isDefined) x else render(x)).getOrElse(render(v))
      s"""  "$k": $r"""
    }.mkString("{\n", ",\n", "\n}\n")
    fromJson(text, s"spec $spec")
  }

  /** Reads the constructor fields back; derived fields in the file are ignored (they are recomputed). */
  def fromJson(text: String, origin: String = "<json>"): ElasParams = {
    val m = FlatJson.parse(text, origin)
    val d = ElasParams()
    def int(k: String, default: Int): Int = m.get(k).map {
      case n: Double if n == math.rint(n) && n.abs <= Int.MaxValue => n.toInt
      case other => throw new IllegalArgumentException(s"$origin: $k must be an integer, got $other")
    }.getOrElse(default)
    def dbl(k: String, default: Double): Double = m.get(k).map {
      case n: Double => n
      case other => throw new IllegalArgumentException(s"$origin: $k must be a number, got $other")
    }.getOrElse(default)
    def str(k: String, default: String): String = m.get(k).map {
      case s: String => s
      case other => throw new IllegalArgumentException(s"$origin: $k must be a string, got $other")
    }.getOrElse(default)
    ElasParams(
      name = str("name", Paths.get(origin).getFileName.toString.stripSuffix(".json")),
      maxWidth = int("maxWidth", d.maxWidth),
      maxHeight = int("maxHeight", d.maxHeight),
      dispMax = int("dispMax", d.dispMax),
      windowSize = int("windowSize", d.windowSize),
      storedDisparities = int("storedDisparities", d.storedDisparities),
      candidateStep = int("candidateStep", d.candidateStep),
      gridSize = int("gridSize", d.gridSize),
      parameterSet = ParameterSet.byName(str("parameterSet", d.parameterSet.name)),
      supportTexture = int("supportTexture", d.supportTexture),
      supportMinRange = int("supportMinRange", d.supportMinRange),
      inconWindowSize = int("inconWindowSize", d.inconWindowSize),
      inconThreshold = int("inconThreshold", d.inconThreshold),
      inconMinSupport = int("inconMinSupport", d.inconMinSupport),
      lrThreshold = int("lrThreshold", d.lrThreshold),
      beta = dbl("beta", d.beta),
      sigma = dbl("sigma", d.sigma),
      speckleSimThreshold = int("speckleSimThreshold", d.speckleSimThreshold),
      speckleSize = int("speckleSize", d.speckleSize),
      speckleWindowRows = int("speckleWindowRows", d.speckleWindowRows),
      ipolColumnWindow = int("ipolColumnWindow", d.ipolColumnWindow),
      fillRule = FillRule.byName(str("fillRule", d.fillRule.name)),
      fillEpsilon = int("fillEpsilon", d.fillEpsilon),
      sDelta = int("sDelta", d.sDelta),
      epsilon = int("epsilon", d.epsilon),
      fillC = int("fillC", d.fillC),
      cyclesPerPixel = int("cyclesPerPixel", d.cyclesPerPixel),
      supportLanes = int("supportLanes", d.supportLanes),
      denseLanes = int("denseLanes", d.denseLanes)
    )
  }
}

/** A minimal parser for one JSON object of numbers, strings, arrays and objects (no escapes, no literals):
  * numbers are Doubles, arrays Seqs, objects Maps.
  */
object FlatJson {
  def parse(text: String, origin: String): Map[String, Any] = {
    var i = 0
    def fail(msg: String) = throw new IllegalArgumentException(s"$origin: malformed JSON at offset $i: $msg")
    def ws(): Unit = while (i < text.length && text(i).isWhitespace) i += 1
    def expect(c: Char): Unit = { ws(); if (i >= text.length || text(i) != c) fail(s"expected '$c'"); i += 1 }
    def string(): String = {
      expect('"'); val start = i
      while (i < text.length && text(i) != '"') { if (text(i) == '\\') fail("escapes are not supported"); i += 1 }
      if (i >= text.length) fail("unterminated string")
      val s = text.substring(start, i); i += 1; s
    }
    def number(): Double = {
      ws(); val start = i
      while (i < text.length && "+-0123456789.eE".contains(text(i))) i += 1
      text.substring(start, i).toDoubleOption.getOrElse(fail("expected a number"))
    }
    def value(): Any = {
      ws()
      if (i >= text.length) fail("unexpected end")
      text(i) match {
        case '"' => string()
        case '[' =>
          i += 1; ws()
          val xs = scala.collection.mutable.ArrayBuffer[Any]()
          if (i < text.length && text(i) == ']') { i += 1 }
          else {
            var more = true
            while (more) { xs += value(); ws(); if (i < text.length && text(i) == ',') i += 1 else { expect(']'); more = false } }
          }
          xs.toSeq
        case '{' => obj()
        case _ => number()
      }
    }
    def obj(): Map[String, Any] = {
      expect('{')
      val out = scala.collection.mutable.LinkedHashMap[String, Any]()
      ws()
      if (i < text.length && text(i) == '}') i += 1
      else {
        var more = true
        while (more) {
          val k = string(); expect(':'); out(k) = value(); ws()
          if (i < text.length && text(i) == ',') i += 1 else { expect('}'); more = false }
        }
      }
      out.toMap
    }
    val out = obj()
    ws(); if (i != text.length) fail("trailing text")
    out
  }
}
