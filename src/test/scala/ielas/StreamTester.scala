package ielas

import chisel3._
import chisel3.util.DecoupledIO
import chiseltest._
import chiseltest.internal.CachingAnnotation
import chiseltest.simulator.{VerilatorBackendAnnotation, VerilatorFlags, WriteVcdAnnotation}
import chisel3.reflect.DataMirror
import firrtl2.options.TargetDirAnnotation

import java.nio.file.{Files, Path, Paths}
import scala.util.Random

/** The one stream-driving helper of every stage test and simulation program. All simulator-specific code
  * (chiseltest, Verilator, VCD, peek/poke) lives in this file, so a move to another simulator touches one file.
  *
  * A run is a single-threaded cycle loop (no fork): each cycle it offers the next input beat unless a seeded random
  * gap says not to, drives the output ready from a seeded random back-pressure pattern, hands every output transfer
  * to a sink, and fails when the cycle bound is exceeded.
  */
object StreamTester {
  /** Input-gap and output-stall probabilities per cycle; both 0 = the no-stall mode of the throughput checks. */
  case class Traffic(inputGap: Double, outputStall: Double) {
    require(inputGap >= 0 && inputGap < 1 && outputStall >= 0 && outputStall < 1, s"traffic: bad probabilities $this")
  }
  val noStall: Traffic = Traffic(0.0, 0.0)
  val choppy: Traffic = Traffic(0.3, 0.3)

  /** The run's seed: -Dielas.seed=N, else $IELAS_SEED, else random; always printed so a failure can be replayed. */
  lazy val seed: Long = {
    val s = sys.props.get("ielas.seed").orElse(sys.env.get("IELAS_SEED")).map(_.trim.toLong).getOrElse(Random.nextLong())
    println(s"StreamTester: seed $s (replay with -Dielas.seed=$s or IELAS_SEED=$s)")
    s
  }

  /** VCD output on request: -Dielas.vcd=1 or IELAS_VCD=1. */
  def vcd: Boolean = sys.props.get("ielas.vcd").orElse(sys.env.get("IELAS_VCD")).contains("1")

  /** Elaborates `gen`, builds it with Verilator into `workDir` and runs `body` on it. With `cache`, an identical
    * circuit reuses the Verilator build already in `workDir`. With `randomInit = Some(seed)` the model starts from a
    * random power-up state (see [[RandomInit]]); the body then runs before any reset, so it must reset the module.
    */
  def simulate[M <: Module](gen: => M, workDir: Path, cache: Boolean = false, randomInit: Option[Long] = None)(
      body: M => Unit): Unit = {
    val relative = Paths.get("").toAbsolutePath.relativize(workDir.toAbsolutePath) // chiseltest wants it relative
    val annos = Seq(VerilatorBackendAnnotation, TargetDirAnnotation(relative.toString)) ++
      (if (vcd) Seq(WriteVcdAnnotation) else Nil) ++ (if (cache) Seq(CachingAnnotation) else Nil) ++
      randomInit.map(s => RandomInit.prepare(workDir, s)).getOrElse(Nil)
    RawTester.test(gen, annos, workDir.getFileName.toString) { dut =>
      dut.clock.setTimeout(0) // the cycle bound below replaces chiseltest's idle timeout
      if (randomInit.nonEmpty) RandomInit.unpinInputs(dut)
      body(dut)
    }
  }

  /** Verilator's random power-up state for [[simulate]]: every register, memory and input starts from values drawn
    * from a seed (`--x-assign unique --x-initial unique`, `Verilated::randReset(2)`).
    *
    * chiseltest builds the model before it hands plusargs over, so `+verilator+seed` comes too late: a C++ hook linked
    * into the model sets the seed in a static initialiser, which runs when chiseltest loads the library, before the
    * model is constructed. The hook reads the seed from a file in the work directory (so one cached build serves every
    * seed; chiseltest loads a fresh copy of the library for each run) and writes back what it applied, which
    * [[applied]] reads as proof.
    */
  object RandomInit {
    def seedFile(workDir: Path): Path = workDir.toAbsolutePath.resolve("random-init-seed")
    def appliedFile(workDir: Path): Path = workDir.toAbsolutePath.resolve("random-init-applied")

    /** Writes the hook and the seed; returns the Verilator annotations. */
    def prepare(workDir: Path, seed: Long): Seq[firrtl2.annotations.Annotation] = {
      Files.createDirectories(workDir)
      val hook = workDir.toAbsolutePath.resolve("random_init_hook.cpp")
      val text =
        s"""// Written by StreamTester.RandomInit: random power-up state from a seed read at load time.
           |#include <verilated.h>
           |#include <cstdio>
           |#include <cstdlib>
           |namespace {
           |struct RandomInitHook {
           |  RandomInitHook() {
           |    long long seed = 0;
           |    FILE* f = std::fopen("${seedFile(workDir)}", "r");
           |    if (!f || std::fscanf(f, "%lld", &seed) != 1) { std::fprintf(stderr, "random init: no seed\\n"); std::abort(); }
           |    std::fclose(f);
           |    // Verilator's seed is an int and 0 means "from the clock": fold the 64-bit seed into 1..2^31-1.
           |    int s = (int)((((unsigned long long)seed) ^ (((unsigned long long)seed) >> 31)) % 2147483646ULL) + 1;
           |    Verilated::randReset(2);
           |    Verilated::randSeed(s);
           |    FILE* a = std::fopen("${appliedFile(workDir)}", "w");
           |    if (a) { std::fprintf(a, "%lld %d %d\\n", seed, Verilated::randReset(), Verilated::randSeed()); std::fclose(a); }
           |  }
           |} hook;
           |}
           |""".stripMargin
      Files.write(hook, text.getBytes)
      Files.write(seedFile(workDir), s"$seed\n".getBytes)
      Files.deleteIfExists(appliedFile(workDir))
      Seq(VerilatorFlags(Seq("--x-assign", "unique", "--x-initial", "unique", hook.toString)))
    }

    /** What the hook applied in this run: (seed, randReset, Verilator seed); None when it did not run. */
    def applied(workDir: Path): Option[(Long, Int, Int)] = {
      val f = appliedFile(workDir)
      if (!Files.exists(f)) None
      else new String(Files.readAllBytes(f)).trim.split(" ") match {
        case Array(a, b, c) => Some((a.toLong, b.toInt, c.toInt))
        case _ => None
      }
    }

    /** chiseltest assumes every input starts at 0 and drops a first poke of 0, which would leave an input at its
      * random value: poke each input (reset included) to another value and back to 0.
      */
    def unpinInputs(dut: Module): Unit =
      for ((_, port) <- DataMirror.modulePorts(dut); leaf <- DataMirror.collectLeafMembers(port)
           if DataMirror.directionOf(leaf) == ActualDirection.Input && leaf.getWidth > 0) leaf match {
        case b: Bool => b.poke(true.B); b.poke(false.B)
        case u: UInt => u.poke(1.U); u.poke(0.U)
        case s: SInt => s.poke(-1.S); s.poke(0.S)
        case _ => // clock
      }
  }

  /** Plain port access for single signals (reset, configuration inputs, status outputs). */
  def poke(port: UInt, value: BigInt): Unit = port.poke(value.U)
  def poke(port: Bool, value: Boolean): Unit = port.poke(value.B)
  def poke(port: SInt, value: BigInt): Unit = port.poke(value.S)
  def peek(port: UInt): BigInt = port.peek().litValue
  def peek(port: SInt): BigInt = port.peek().litValue
  def peek(port: Bool): Boolean = port.peek().litToBoolean
  def step(clock: Clock, cycles: Int = 1): Unit = if (cycles > 0) clock.step(cycles)

  /** Resets the module for a few cycles. */
  def reset(dut: Module, cycles: Int = 2): Unit = {
    dut.reset.poke(true.B); dut.clock.step(cycles); dut.reset.poke(false.B)
  }

  /** Streams `inputs` into `in` and hands the first `expectedOutputs` transfers of `out` to `sink` (in order, with
    * their index). Returns the cycles from the first offered input to the last expected output transfer, inclusive.
    * `pokeBeat` sets the input bits; `peekBeat` reads the output bits (called only on a transfer).
    * Throws when `maxCycles` pass first. `onCycle` runs once per cycle before the clock edge (side channels);
    * `stopWhen` ends the run early (for streams whose output count is not known in advance).
    */
  def run[D <: Data, E <: Data, I, O](clock: Clock, in: DecoupledIO[D], inputs: Iterator[I], pokeBeat: (D, I) => Unit,
      out: DecoupledIO[E], expectedOutputs: Long, peekBeat: E => O, sink: (Long, O) => Unit,
      traffic: Traffic, rnd: Random, maxCycles: Long, what: String = "stream", onCycle: () => Unit = () => (),
      stopWhen: () => Boolean = () => false): Long = {
    var cycles = 0L
    var received = 0L
    var pending: Option[I] = None
    var offered = false
    var lastValid: Option[Boolean] = None
    var lastReady: Option[Boolean] = None
    while (!stopWhen() && (received < expectedOutputs || pending.nonEmpty || inputs.hasNext)) {
      if (cycles >= maxCycles)
        throw new AssertionError(s"$what: timeout after $cycles cycles with $received of $expectedOutputs outputs " +
          s"(seed ${seed})")
      if (pending.isEmpty && inputs.hasNext) pending = Some(inputs.next())
      val offer = pending.nonEmpty && rnd.nextDouble() >= traffic.inputGap
      if (offer) { pokeBeat(in.bits, pending.get); offered = true }
      if (!lastValid.contains(offer)) { in.valid.poke(offer.B); lastValid = Some(offer) } // pokes cost time: only changes
      val ready = rnd.nextDouble() >= traffic.outputStall
      if (!lastReady.contains(ready)) { out.ready.poke(ready.B); lastReady = Some(ready) }
      if (offer && in.ready.peek().litToBoolean) pending = None
      if (ready && out.valid.peek().litToBoolean) {
        if (received < expectedOutputs) sink(received, peekBeat(out.bits))
        else throw new AssertionError(s"$what: more than the $expectedOutputs expected outputs (seed $seed)")
        received += 1
      }
      onCycle()
      clock.step()
      if (offered) cycles += 1
    }
    in.valid.poke(false.B)
    out.ready.poke(false.B)
    cycles
  }

  /** A stream that hands its input on unchanged (a slice, a queue): seeded random 16-bit values under choppy, mostly
    * gappy, mostly stalled and stall-free traffic must come out complete and in order (expected: the input itself),
    * and without stalls within `n + noStallSlack` cycles. `drain` clocks follow each run (it stops at the last beat).
    */
  def checkPassThrough(clock: Clock, in: DecoupledIO[UInt], out: DecoupledIO[UInt], rnd: Random, noStallSlack: Int,
      drain: Int, what: String): Unit =
    for ((traffic, n) <- Seq((choppy, 4000), (Traffic(0.6, 0.1), 1000), (Traffic(0.1, 0.6), 1000), (noStall, 2000))) {
      val values = Seq.fill(n)(BigInt(16, rnd))
      val got = Array.fill[BigInt](n)(-1)
      val cycles = run[UInt, UInt, BigInt, BigInt](clock, in, values.iterator, (b, v) => poke(b, v), out, n,
        b => peek(b), (i, v) => got(i.toInt) = v, traffic, rnd, 20L * n + 100, s"$what $traffic")
      val wrong = (0 until n).filter(i => got(i) != values(i))
      assert(wrong.isEmpty, s"$what $traffic: ${wrong.size} of $n beats wrong, first at ${wrong.headOption}")
      if (traffic == noStall) assert(cycles <= n + noStallSlack, s"$what, no stalls: $n beats took $cycles cycles")
      step(clock, drain)
    }

  /** One input port of [[runFeeds]]: its beats, how to poke one, and its own seeded gap probability and generator,
    * so each input of a multi-input stage sees an independent random gap pattern.
    */
  final class Feed[D <: Data, I](val name: String, port: DecoupledIO[D], inputs: Iterator[I], pokeBeat: (D, I) => Unit,
      val inputGap: Double, rnd: Random) {
    require(inputGap >= 0 && inputGap < 1, s"feed $name: bad gap probability $inputGap")
    private var pending: Option[I] = None
    private var lastValid: Option[Boolean] = None
    private var offer = false
    /** Beats transferred so far. */
    var sent = 0L
    def busy: Boolean = pending.nonEmpty || inputs.hasNext
    /** Offers the next beat unless a gap is drawn; returns whether a beat is offered. */
    private[StreamTester] def drive(): Boolean = {
      if (pending.isEmpty && inputs.hasNext) pending = Some(inputs.next())
      offer = pending.nonEmpty && rnd.nextDouble() >= inputGap
      if (offer) pokeBeat(port.bits, pending.get)
      if (!lastValid.contains(offer)) { port.valid.poke(offer.B); lastValid = Some(offer) }
      offer
    }
    /** After every input is driven: did the offered beat transfer? */
    private[StreamTester] def sample(): Unit =
      if (offer && port.ready.peek().litToBoolean) { pending = None; sent += 1 }
    private[StreamTester] def stop(): Unit = { port.valid.poke(false.B); lastValid = Some(false) }
  }

  /** The multi-input form of [[run]]: every feed offers its beats with its own gaps (all inputs are driven before
    * any ready is sampled), the output is drained under seeded back-pressure `outputStall`, and the first
    * `expectedOutputs` transfers go to `sink`. Returns the cycles from the first offered input (of any feed) to the
    * last expected output, inclusive; throws when `maxCycles` pass first, naming how far each feed got.
    */
  def runFeeds[E <: Data, O](clock: Clock, feeds: Seq[Feed[_ <: Data, _]], out: DecoupledIO[E], expectedOutputs: Long,
      peekBeat: E => O, sink: (Long, O) => Unit, outputStall: Double, rnd: Random, maxCycles: Long,
      what: String = "stream"): Long = {
    require(outputStall >= 0 && outputStall < 1, s"$what: bad stall probability $outputStall")
    var cycles = 0L
    var received = 0L
    var started = false
    var lastReady: Option[Boolean] = None
    while (received < expectedOutputs || feeds.exists(_.busy)) {
      if (cycles >= maxCycles)
        throw new AssertionError(s"$what: timeout after $cycles cycles with $received of $expectedOutputs outputs; " +
          feeds.map(f => s"${f.name} sent ${f.sent}${if (f.busy) " (more pending)" else ""}").mkString(", ") +
          s" (seed $seed)")
      val offered = feeds.map(_.drive()).exists(identity)
      val ready = rnd.nextDouble() >= outputStall
      if (!lastReady.contains(ready)) { out.ready.poke(ready.B); lastReady = Some(ready) }
      feeds.foreach(_.sample())
      if (ready && out.valid.peek().litToBoolean) {
        if (received < expectedOutputs) sink(received, peekBeat(out.bits))
        else throw new AssertionError(s"$what: more than the $expectedOutputs expected outputs (seed $seed)")
        received += 1
      }
      clock.step()
      started ||= offered
      if (started) cycles += 1
    }
    feeds.foreach(_.stop())
    out.ready.poke(false.B)
    cycles
  }

  /** One output beat of the descriptor stream: both descriptors (byte k at bits 8k+7..8k) and the framing. */
  /** One beat of the pixel-pair input stream. */
  case class PixelBeat(left: Int, right: Int, sof: Boolean, eol: Boolean)
  /** The input beats of frames (left, right) back to back, each in raster order. */
  def pixelBeats(frames: Seq[(GrayImage, GrayImage)]): Iterator[PixelBeat] = frames.iterator.flatMap { case (l, r) =>
    val w = l.width
    Iterator.range(0, w * l.height).map(i => PixelBeat(l.pixels(i) & 0xff, r.pixels(i) & 0xff, i == 0, i % w == w - 1))
  }
  def pokePixel(bits: PixelPair, b: PixelBeat): Unit = {
    poke(bits.left, b.left); poke(bits.right, b.right); poke(bits.sof, b.sof); poke(bits.eol, b.eol)
  }

  case class DescriptorBeat(left: BigInt, right: BigInt, sof: Boolean, eol: Boolean, eof: Boolean)

  /** Streams same-size frames back to back into a [[DescriptorChain]] (frameWidth/frameHeight held at their size) and
    * hands each output beat to `sink` with its flat index over all frames. Returns the cycle count of [[run]].
    */
  def streamDescriptorFrames(dut: DescriptorChain, frames: Seq[(GrayImage, GrayImage)], traffic: Traffic, rnd: Random,
      sink: (Long, DescriptorBeat) => Unit, maxCycles: Long, what: String): Long = {
    val (w, h) = (frames.head._1.width, frames.head._1.height)
    require(frames.forall { case (l, r) => l.width == w && r.width == w && l.height == h && r.height == h },
      s"$what: all frames of one run need the same size")
    dut.io.frameWidth.poke(w.U)
    dut.io.frameHeight.poke(h.U)
    dut.io.clearError.poke(false.B)
    var lastSof: Option[Boolean] = None
    var lastEol: Option[Boolean] = None
    run[PixelPair, Framed[DescriptorPair], PixelBeat, DescriptorBeat](dut.clock, dut.io.in, pixelBeats(frames),
      (bits, b) => {
        bits.left.poke(b.left.U); bits.right.poke(b.right.U)
        if (!lastSof.contains(b.sof)) { bits.sof.poke(b.sof.B); lastSof = Some(b.sof) }
        if (!lastEol.contains(b.eol)) { bits.eol.poke(b.eol.B); lastEol = Some(b.eol) }
      },
      dut.io.out, frames.length.toLong * w * h,
      o => DescriptorBeat(o.data.left.peek().litValue, o.data.right.peek().litValue, o.sof.peek().litToBoolean,
        o.eol.peek().litToBoolean, o.eof.peek().litToBoolean),
      sink, traffic, rnd, maxCycles, what)
  }

  /** A scratch directory under build/test-tmp. */
  def tmpDir(name: String): Path = Paths.get("build", "test-tmp", name).toAbsolutePath
}
