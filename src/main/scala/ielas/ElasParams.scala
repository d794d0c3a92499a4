package ielas

import chisel3.util.log2Ceil
import scala.language.implicitConversions

/** The ELAS algorithm parameter set (libelas's two presets; docs/ALGORITHM.md, "Configurations and frames").
  * It fixes the support, prior and post-processing parameters; the hardware shape comes from [[ElasParams]].
  */
sealed abstract class ParameterSet(val name: String) {
  def supportThresholdPercent: Int // best/second-best cost ratio limit, in percent (0.85 -> 85)
  def gamma: Double
  def sradius: Double
  def matchTexture: Int
  def addCorners: Boolean
  def ipolGapWidth: Int
  def filterMedian: Boolean
  def filterAdaptiveMean: Boolean
  def postprocessOnlyLeft: Boolean
}

object ParameterSet {
  case object Robotics extends ParameterSet("robotics") {
    val supportThresholdPercent = 85; val gamma = 3.0; val sradius = 2.0; val matchTexture = 1
    val addCorners = false; val ipolGapWidth = 3; val filterMedian = false; val filterAdaptiveMean = true
    val postprocessOnlyLeft = true
  }
  case object Middlebury extends ParameterSet("middlebury") {
    val supportThresholdPercent = 95; val gamma = 5.0; val sradius = 3.0; val matchTexture = 0
    val addCorners = true; val ipolGapWidth = 5000; val filterMedian = true; val filterAdaptiveMean = false
    val postprocessOnlyLeft = false
  }
  val all: Seq[ParameterSet] = Seq(Robotics, Middlebury)
  def byName(name: String): ParameterSet =
    all.find(_.name == name).getOrElse(
      throw new IllegalArgumentException(s"parameterSet: unknown '$name' (legal: ${all.map(_.name).mkString(", ")})"))
}

/** Lattice-fill rule for nodes of the support lattice that hold no support point. */
sealed abstract class FillRule(val name: String)
object FillRule {
  /** Row-linear interpolation with an up-select for disparity jumps (docs/ALGORITHM.md, "The fill study"); one lattice row look-ahead. */
  case object R7 extends FillRule("r7")
  /** The iELAS paper: horizontal within +-sDelta px, then vertical, then the constant C. */
  case object Paper extends FillRule("paper")
  val all: Seq[FillRule] = Seq(R7, Paper)
  def byName(name: String): FillRule =
    all.find(_.name == name).getOrElse(
      throw new IllegalArgumentException(s"fillRule: unknown '$name' (legal: ${all.map(_.name).mkString(", ")})"))
}

/** A bound of a legal range: a constant, or a card parameter's value (plus a constant), or the cell count of a
  * square window. [[ConfigJson]] writes it as an integer or as a string the golden model evaluates: `"dispMax+1"`,
  * `"maxWidth-1"`, `"candidateStep"`, `"(2*inconWindowSize+1)^2"`.
  */
sealed abstract class Bound {
  def eval(int: String => Int): Int
  def json: String
}
object Bound {
  final case class Const(k: Int) extends Bound {
    def eval(int: String => Int): Int = k
    def json: String = k.toString
  }
  final case class Param(field: String, plus: Int = 0) extends Bound {
    def eval(int: String => Int): Int = int(field) + plus
    def json: String = "\"" + field + (if (plus > 0) s"+$plus" else if (plus < 0) plus.toString else "") + "\""
  }
  final case class WindowArea(field: String) extends Bound {
    def eval(int: String => Int): Int = { val n = 2 * int(field) + 1; n * n }
    def json: String = "\"(2*" + field + "+1)^2\""
  }
  implicit def const(k: Int): Bound = Const(k)
}

/** One legality rule of a card parameter. [[ElasParams]] checks its fields against [[ElasParams.legal]] and
  * [[ConfigJson]] writes the same rules into the configuration JSON's `"legal"` object, where the golden model reads
  * them: `["range", lo, hi]`, `["aboveUpTo", lo, hi]`, `["oneOf", v, ...]`, `["zeroOrPowerOfTwo", lo, hi]`.
  */
sealed abstract class Legal {
  def param: String
  /** None when `value` is legal, else the one-line message; `int` gives the other integer parameters. */
  def check(value: Any, int: String => Int): Option[String]
  def json: String
}
object Legal {
  type Message = (Any, Int, Int, String => Int) => String // value, lo, hi, parameters

  final case class Range(param: String, lo: Bound, hi: Bound, message: Option[Message] = None) extends Legal {
    def check(value: Any, int: String => Int): Option[String] = {
      val (l, h, v) = (lo.eval(int), hi.eval(int), value.asInstanceOf[Int])
      if (v >= l && v <= h) None
      else Some(message.fold(s"$param = $v is out of range (legal: $l..$h)")(_(v, l, h, int)))
    }
    def json: String = s"""["range", ${lo.json}, ${hi.json}]"""
  }
  /** lo < value <= hi, for the real-valued parameters. */
  final case class AboveUpTo(param: String, lo: Double, hi: Double) extends Legal {
    private def fmt(x: Double) = if (x == math.rint(x)) x.toLong.toString else x.toString
    def check(value: Any, int: String => Int): Option[String] = {
      val v = value.asInstanceOf[Double]
      if (v > lo && v <= hi) None else Some(s"$param = $v is out of range (legal: (${fmt(lo)}, ${fmt(hi)}])")
    }
    def json: String = s"""["aboveUpTo", ${fmt(lo)}, ${fmt(hi)}]"""
  }
  final case class OneOf(param: String, values: Seq[Any]) extends Legal {
    def check(value: Any, int: String => Int): Option[String] =
      if (values.contains(value)) None
      else value match {
        case _: String => Some(s"$param: unknown '$value' (legal: ${values.mkString(", ")})")
        case _         => Some(s"$param = $value is not supported (legal: ${values.mkString(", ")})")
      }
    def json: String = values.map {
      case s: String => "\"" + s + "\""
      case other     => other.toString
    }.mkString("[\"oneOf\", ", ", ", "]")
  }
  /** 0 or a power of two in lo..hi. */
  final case class ZeroOrPowerOfTwo(param: String, lo: Bound, hi: Bound, message: Option[Message] = None) extends Legal {
    def check(value: Any, int: String => Int): Option[String] = {
      val (l, h, v) = (lo.eval(int), hi.eval(int), value.asInstanceOf[Int])
      if (v == 0 || (v >= l && v <= h && Integer.bitCount(v) == 1)) None
      else {
        val legal = (0 +: Iterator.iterate(1)(_ * 2).takeWhile(_ <= h).filter(_ >= l).toSeq).mkString(", ")
        Some(message.fold(s"$param = $v is not supported (legal: $legal)")(_(v, l, h, int)))
      }
    }
    def json: String = s"""["zeroOrPowerOfTwo", ${lo.json}, ${hi.json}]"""
  }
}

/** The single source of truth for the generator and the golden model.
  *
  * Card parameters: image size maxima, disparity range, window size, stored disparities. Everything else has the
  * libelas default for the chosen parameter set. [[ConfigJson]] writes it (with the derived tables) to
  * `golden/configs/<name>.json`, which the C++ golden model reads, so no value is typed twice.
  */
case class ElasParams(
    name: String = "custom",
    maxWidth: Int = 1242,
    maxHeight: Int = 376,
    dispMax: Int = 255,
    windowSize: Int = 5,
    storedDisparities: Int = 20,
    candidateStep: Int = 5,
    gridSize: Int = 20,
    parameterSet: ParameterSet = ParameterSet.Robotics,
    // support matching and filtering (docs/ALGORITHM.md, "support")
    supportTexture: Int = 10,
    supportMinRange: Int = 10,
    inconWindowSize: Int = 5,
    inconThreshold: Int = 5,
    inconMinSupport: Int = 5,
    lrThreshold: Int = 2,
    // prior (docs/ALGORITHM.md, "dense")
    beta: Double = 0.02,
    sigma: Double = 1.0,
    // post-processing (docs/ALGORITHM.md, "post") and its bounded streaming forms
    speckleSimThreshold: Int = 1,
    speckleSize: Int = 200,
    speckleWindowRows: Int = 16,
    ipolColumnWindow: Int = 32,
    // lattice fill
    fillRule: FillRule = FillRule.R7,
    fillEpsilon: Int = 15,
    sDelta: Int = 50,
    epsilon: Int = 15,
    fillC: Int = 60,
    // implementation knobs
    cyclesPerPixel: Int = 1, // the input takes at most one pixel every cyclesPerPixel clocks; lane counts follow
    supportLanes: Int = 0, //   0 = the lowest count that keeps up with one pixel every cyclesPerPixel clocks
    denseLanes: Int = 0 //      0 = likewise (candidates per view / cyclesPerPixel, rounded up)
) {
  require(name.nonEmpty && name.forall(c => c.isLetterOrDigit || c == '-' || c == '_'),
    s"name = '$name' must be non-empty and use only letters, digits, '-' and '_'")
  /** A card parameter's value by its field name (an Int, a Double or, for the sets and the fill rule, a name). */
  def param(field: String): Any =
    productElementNames.zip(productIterator).collectFirst { case (`field`, v) => v } match {
      case Some(s: ParameterSet) => s.name
      case Some(f: FillRule)     => f.name
      case Some(v)               => v
      case None                  => throw new IllegalArgumentException(s"ElasParams: no parameter '$field'")
    }
  private def intParam(field: String): Int = param(field) match {
    case i: Int => i
    case other  => throw new IllegalArgumentException(s"ElasParams: parameter '$field' = $other is not an integer")
  }
  ElasParams.legal.foreach(rule => rule.check(param(rule.param), intParam).foreach(msg => require(false, msg)))

  // ---- derived values ----
  /** Half window: descriptor and support-window reach in pixels (2 for ELAS's 5x5). */
  val windowRadius: Int = windowSize / 2
  /** Descriptor bytes per pixel: the ELAS 16-byte layout at every window size (docs/ALGORITHM.md). */
  val descriptorBytes: Int = 16
  /** Pixels from the border where descriptors are defined (non-zero): windowRadius + 1 (Sobel reach). */
  val descriptorMargin: Int = windowRadius + 1
  /** Pixels from the border where support points can be matched: window corners + descriptor margin. */
  val supportMargin: Int = windowRadius + descriptorMargin
  /** Lattice nodes per row/column: u = 0, step, 2*step, ..., plus a last node at W-1 when it is not on the step. */
  def latticeCount(pixels: Int): Int = (pixels + candidateStep - 1) / candidateStep + (if ((pixels - 1) % candidateStep != 0) 1 else 0)
  val latticeColsMax: Int = latticeCount(maxWidth)
  val latticeRowsMax: Int = latticeCount(maxHeight)
  def gridCount(pixels: Int): Int = (pixels + gridSize - 1) / gridSize
  val gridColsMax: Int = gridCount(maxWidth)
  val gridRowsMax: Int = gridCount(maxHeight)
  val supportThresholdPercent: Int = parameterSet.supportThresholdPercent
  val gamma: Double = parameterSet.gamma
  val sradius: Double = parameterSet.sradius
  val planeRadius: Int = math.max(math.ceil(sigma * sradius).toInt, 2)
  val matchTexture: Int = parameterSet.matchTexture
  val addCorners: Boolean = parameterSet.addCorners
  val ipolGapWidth: Int = parameterSet.ipolGapWidth
  val filterMedian: Boolean = parameterSet.filterMedian
  val filterAdaptiveMean: Boolean = parameterSet.filterAdaptiveMean
  val postprocessOnlyLeft: Boolean = parameterSet.postprocessOnlyLeft

  /** Integer prior P[delta], delta = |d - d_plane| = 0..dispMax (docs/ALGORITHM.md, "dense"): trunc((ln g - ln(g + N)) / beta). */
  val priorTable: Seq[Int] = (0 to dispMax).map(ElasParams.priorEntry(_, gamma, sigma, beta))

  /** Widths. */
  val dispBits: Int = log2Ceil(dispMax + 1)
  /** A disparity as a signed value: 0..dispMax, or -1 for none (lattice, grid and dense streams). */
  val signedDispBits: Int = dispBits + 1
  val colBits: Int = log2Ceil(maxWidth + 1)
  val rowBits: Int = log2Ceil(maxHeight + 1)

  /** Support search cost evaluations per lattice point (left search and right check, 0..dispMax each),
    * and the cycles one lattice point may take at 1 input pixel per clock (step rows x step columns).
    */
  val supportCyclesPerPoint: Int = cyclesPerPixel * candidateStep * candidateStep
  /** Support SAD lanes = column banks: a power of two above 2r (lane k reads bank k of an aligned block of
    * columns). The lowest that schedules a node in supportCyclesPerPoint, else the one that sweeps in one block.
    */
  val supportLanesUsed: Int =
    if (supportLanes > 0) supportLanes
    else {
      val widths = Iterator.iterate(1 << log2Ceil(2 * windowRadius + 1))(_ * 2).takeWhile(_ <= dispMax + 1).toSeq
      widths.find(l => ElasParams.supportNodeCycles(dispMax, windowRadius, l) <= supportCyclesPerPoint)
        .getOrElse(widths.last)
    }
  /** Dense candidates per pixel: the plane range plus the grid candidates. */
  val denseCandidates: Int = 2 * planeRadius + 1 + storedDisparities
  /** Dense SAD lanes per view; each pixel's candidates are evaluated in denseGroups cycles of denseLanesUsed. */
  val denseLanesUsed: Int =
    if (denseLanes > 0) denseLanes else (denseCandidates + cyclesPerPixel - 1) / cyclesPerPixel
  val denseGroups: Int = (denseCandidates + denseLanesUsed - 1) / denseLanesUsed
  require(denseGroups <= cyclesPerPixel, s"denseLanes = $denseLanes is too few for cyclesPerPixel = $cyclesPerPixel" +
    s" (legal: 0 or ${(denseCandidates + cyclesPerPixel - 1) / cyclesPerPixel}..${dispMax + 1})")
}

object ElasParams {
  /** Fixed cycles a support point spends outside its lane sweeps: its two reference reads. The next node's left
    * sweep runs while the search pipeline computes a node's left result, so no cycle waits for it, except at the
    * last searched node of a lattice row (supportDrainCycles).
    */
  val supportOverheadCycles: Int = 2

  /** Cycles the last searched node of a lattice row waits between its left sweep and its right reference read (the
    * SupportMatcher search pipeline's depth and the registered right-sweep setup). The row's first node, never
    * searched (it lies in the margin), takes one cycle of its supportCyclesPerPoint.
    */
  val supportDrainCycles: Int = 10

  /** Cycles of one support sweep over disparities 0..dhi at the worst alignment: the target columns t - r .. t + r
    * of all of them span dhi + 2r + 1 columns, i.e. at most ceil((dhi + 2r) / lanes) + 1 aligned blocks.
    */
  def supportSweepCycles(dhi: Int, windowRadius: Int, lanes: Int): Int = (dhi + 2 * windowRadius + lanes - 1) / lanes + 1

  /** Worst cycles of one support node (both sweeps over 0..dispMax). */
  def supportNodeCycles(dispMax: Int, windowRadius: Int, lanes: Int): Int =
    supportOverheadCycles + 2 * supportSweepCycles(dispMax, windowRadius, lanes)

  def priorEntry(delta: Int, gamma: Double, sigma: Double, beta: Double): Int = {
    val n = math.exp(-(delta.toDouble * delta) / (2.0 * sigma * sigma))
    ((math.log(gamma) - math.log(gamma + n)) / beta).toInt // toInt truncates toward zero, as libelas
  }

  /** The legal values of every card parameter but the name, checked in this order (the only place they are typed:
    * the configuration JSON carries them to the golden model). Rules that are not ranges of one parameter (the
    * name's characters, denseLanes against the dense candidates per cyclesPerPixel) are checked by ElasParams alone.
    */
  val legal: Seq[Legal] = {
    import Bound._
    import Legal._
    val dispMax = Param("dispMax")
    Seq(
      Range("maxWidth", 32, 8192),
      Range("maxHeight", 16, 8192),
      Range("dispMax", 15, 1023),
      Range("dispMax", 15, Param("maxWidth", -1),
        Some((v, lo, hi, int) => s"dispMax = $v must be below maxWidth = ${int("maxWidth")} (legal: $lo..$hi)")),
      OneOf("windowSize", Seq(3, 5, 7)),
      Range("storedDisparities", 1, Param("dispMax", 1)),
      Range("candidateStep", 2, 16),
      Range("gridSize", Param("candidateStep"), 256),
      OneOf("parameterSet", ParameterSet.all.map(_.name)),
      Range("supportTexture", 0, 2048),
      Range("supportMinRange", 1, dispMax),
      Range("inconWindowSize", 1, 16),
      Range("inconThreshold", 0, dispMax),
      Range("inconMinSupport", 1, WindowArea("inconWindowSize")),
      Range("lrThreshold", 0, dispMax),
      AboveUpTo("beta", 0, 1),
      AboveUpTo("sigma", 0, 16),
      Range("speckleSimThreshold", 0, dispMax),
      Range("speckleSize", 0, 100000),
      Range("speckleWindowRows", 1, 64),
      Range("ipolColumnWindow", 1, 256),
      OneOf("fillRule", FillRule.all.map(_.name)),
      Range("fillEpsilon", 0, dispMax),
      Range("sDelta", 0, Param("maxWidth")),
      Range("epsilon", 0, dispMax),
      Range("fillC", 0, dispMax),
      OneOf("cyclesPerPixel", Seq(1, 2, 4, 8)),
      Range("supportLanes", 0, Param("dispMax", 1)),
      ZeroOrPowerOfTwo("supportLanes", Param("windowSize"), Param("dispMax", 1),
        Some((v, lo, hi, _) => s"supportLanes = $v must be 0 (automatic) or a power of two above windowSize - 1 = ${lo - 1}" +
          s" (legal: 0, ${Iterator.iterate(1)(_ * 2).takeWhile(_ <= hi).filter(_ >= lo).mkString(", ")})")),
      Range("denseLanes", 0, Param("dispMax", 1)))
  }

  /** `value` of `field` moved into its legal ranges, evaluated with the integer parameters `int`. */
  def clampToLegal(field: String, value: Int, int: String => Int): Int =
    legal.collect { case r: Legal.Range if r.param == field => r }
      .foldLeft(value)((v, r) => math.min(math.max(v, r.lo.eval(int)), r.hi.eval(int)))

  /** The card parameters a preset moves into their legal range once the frame size and dispMax are set (fillC =
    * min(60, dispMax)); the golden model's `--preset` does the same with the list in the preset file.
    */
  val presetFollows: Seq[String] = Seq("fillC", "sDelta")

  /** The preset files (golden/configs/presets/<set>.json): the defaults with the parameter set. The golden model's
    * `--preset` takes one and sets the frame size and dispMax.
    */
  def presetBase(set: ParameterSet): ElasParams = ElasParams(name = s"preset-${set.name}", parameterSet = set)

  private def preset(name: String, w: Int, h: Int, dmax: Int, set: ParameterSet, windowSize: Int = 5,
      cyclesPerPixel: Int = 1) = {
    val base = presetBase(set)
    val own = Map("maxWidth" -> w, "maxHeight" -> h, "dispMax" -> dmax)
    val int = (f: String) => own.getOrElse(f, base.param(f).asInstanceOf[Int])
    val follow = presetFollows.map(f => f -> clampToLegal(f, int(f), int)).toMap
    base.copy(name = name, maxWidth = w, maxHeight = h, dispMax = dmax, windowSize = windowSize,
      fillC = follow("fillC"), sDelta = follow("sDelta"), cyclesPerPixel = cyclesPerPixel)
  }

  /** The named configurations of docs/interfaces.md §1, then small ones for fast tests. */
  val named: Seq[ElasParams] = Seq(
    preset("kitti", 1242, 376, 255, ParameterSet.Robotics),
    preset("kitti-middlebury", 1242, 376, 255, ParameterSet.Middlebury),
    preset("kitti-c8", 1242, 376, 255, ParameterSet.Robotics, cyclesPerPixel = 8), // about the iELAS paper's rate
    preset("tsukuba", 640, 480, 127, ParameterSet.Robotics),
    preset("tsukuba-middlebury", 640, 480, 127, ParameterSet.Middlebury),
    // Small test configurations: narrow frames and short disparity ranges so Verilator builds stay fast.
    preset("small", 128, 64, 31, ParameterSet.Robotics),
    preset("small-middlebury", 128, 64, 31, ParameterSet.Middlebury),
    preset("small-w3", 128, 64, 31, ParameterSet.Robotics, windowSize = 3),
    preset("small-w7", 128, 64, 31, ParameterSet.Robotics, windowSize = 7),
    preset("small-c4", 128, 64, 31, ParameterSet.Robotics, cyclesPerPixel = 4),
    preset("mb-tsukuba", 384, 288, 63, ParameterSet.Robotics)
  )

  def byName(name: String): ElasParams =
    named.find(_.name == name).getOrElse(
      throw new IllegalArgumentException(s"configuration: unknown '$name' (legal: ${named.map(_.name).mkString(", ")}, or a .json file)"))
}
