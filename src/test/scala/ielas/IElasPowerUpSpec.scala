package ielas

import chisel3._
import org.scalatest.flatspec.AnyFlatSpec

import java.nio.file.Files
import scala.util.Random

/** Shows that [[StreamTester.RandomInit]] works: a register without reset (its power-up value) and a register that
  * samples an input (which must read the 0 the test drives, not a random power-up value).
  */
class PowerUpProbe extends Module {
  val io = IO(new Bundle {
    val in = Input(UInt(16.W))
    val noReset = Output(UInt(32.W))
    val captured = Output(UInt(16.W))
  })
  val held = Reg(UInt(32.W))
  held := held + io.in // holds while the input is 0; a register with no real driver would be folded to 0
  io.noReset := held
  io.captured := RegNext(io.in)
}

/** The whole accelerator (`IElas`, config small) does not depend on its power-up state: one Verilator build with
  * random initial values ([[StreamTester.RandomInit]]) runs from two different seeds and must give the golden map
  * exactly, the same at both; and a reset in mid-frame (input and output both mid-frame) or while the previous frame's
  * output is still draining is followed by a good frame that must be exact.
  */
class IElasPowerUpSpec extends AnyFlatSpec {
  import IElasEndToEndSpec._
  import StreamTester._

  behavior of "IElas from a random power-up state"

  private val p = ElasParams.byName("small")
  private val tmp = tmpDir("top-powerup-small")
  private val work = tmp.resolve("verilator")
  private val rnd = new Random(seed ^ 0x5eed)
  private val (kl, kr) = TestImages.kitti2012
  private val (tl, tr) = TestImages.middleburyTsukuba
  private lazy val frames = Seq(
    Frame("KITTI 2012 000070 crop 96x48 at (600,170)", kl.crop(600, 170, 96, 48), kr.crop(600, 170, 96, 48)),
    Frame("noise 40x24", TestImages.noise(40, 24, rnd), TestImages.noise(40, 24, rnd)))
  private lazy val big = Frame("Middlebury tsukuba crop 128x64 at (120,110)", tl.crop(120, 110, 128, 64), tr.crop(120, 110, 128, 64))
  private lazy val expected = frames.zipWithIndex.map { case (f, i) => golden(p, f, tmp.resolve(f"golden$i%02d")) }
  private lazy val bigExpected = golden(p, big, tmp.resolve("golden-big"))

  /** One run from the power-up state of `s`: each frame alone under gaps and back-pressure, checked against the
    * golden map. Returns the output beats.
    */
  private def fromSeed(s: Long): Seq[Seq[OutBeat]] = {
    var got = Seq.empty[Seq[OutBeat]]
    simulate(new IElas(p), work, cache = true, randomInit = Some(s)) { dut =>
      val applied = RandomInit.applied(tmp.resolve("verilator"))
      assert(applied.exists(a => a._1 == s && a._2 == 2 && a._3 != 0), s"random init hook did not run with seed $s: $applied")
      reset(dut)
      for ((f, exp) <- frames.zip(expected)) {
        val (_, out) = stream(dut, Seq(f), Traffic(0.3, 0.3), rnd, choppyBound(Seq(f), p), f.label, f.width.toLong * f.height)
        val board = new Scoreboard(s"top [${f.label}] power-up seed $s")
        check(board, f, out.head, exp, 0)
        assert(board.ok, board.report)
        assert(!peek(dut.io.error), s"${f.label}: error raised by a legal frame after a random power-up (seed $s)")
        println(s"  power-up seed $s (Verilator seed ${applied.get._3}): ${board.report}")
        got :+= out.head
      }
    }
    got
  }

  private val (seedA, seedB) = (seed, seed + 0x9e3779b97f4a7c15L)

  it should "start from a power-up state that depends on the seed (a probe through the same helper)" in {
    val probeWork = tmpDir("powerup-probe").resolve("verilator")
    def powerUp(s: Long): (BigInt, BigInt) = {
      var (v, c) = (BigInt(-1), BigInt(-1))
      simulate(new PowerUpProbe, probeWork, cache = true, randomInit = Some(s)) { dut =>
        v = peek(dut.io.noReset)
        c = peek(dut.io.captured) // the input's power-up value (sampled in chiseltest's first reset cycle)
        step(dut.clock)
        assert(peek(dut.io.captured) == 0, s"seed $s: an input kept its random power-up value")
        reset(dut)
        assert(peek(dut.io.noReset) == v, s"seed $s: the register without reset changed")
      }
      println(f"  probe: at seed $s the register without reset powers up as 0x$v%08x, the input as 0x$c%04x (0 once driven)")
      (v, c)
    }
    val ((a, ca), (b, cb)) = (powerUp(seedA), powerUp(seedB))
    // Equal draws (p = 2^-32, 2^-16) or zeros mean the random initial values are not in effect.
    assert(a != b, s"the register without reset powers up as $a at both seeds")
    assert(ca != cb, s"the input powers up as $ca at both seeds")
  }

  it should "give the exact golden map from two random power-up states, identically" in {
    val outA = fromSeed(seedA)
    val outB = fromSeed(seedB)
    // The build of IElas carries the random-init flags and the hook (the probe above shows what they do).
    val cmd = new String(Files.readAllBytes(work.resolve("verilated").resolve("VIElas__verFiles.dat")))
    assert(cmd.contains("--x-assign unique --x-initial unique") && cmd.contains("random_init_hook.cpp"),
      "the IElas Verilator build lacks the random-init flags")
    assert(outA == outB, "the output differs between two power-up states")
  }

  it should "give an exact frame after a reset in mid-frame and after a reset while the output drains" in {
    simulate(new IElas(p), work, cache = true, randomInit = Some(seed ^ 0x7e5e7)) { dut =>
      reset(dut)
      val (w, h) = (big.width, big.height)
      val rows = IElas.latencyRows(p)
      def goodAfter(what: String): Unit = {
        val f = frames.head
        val (_, out) = stream(dut, Seq(f), Traffic(0.2, 0.2), rnd, choppyBound(Seq(f), p), s"$what: good frame", f.width.toLong * f.height)
        val board = new Scoreboard(s"top [$what, then ${f.label}]")
        assert(out.length == 1, s"$what: ${out.length} output frames for one")
        check(board, f, out.head, expected.head, 0)
        assert(board.ok, board.report)
        assert(!peek(dut.io.error), s"$what: error raised by the good frame")
        println(s"  $what: ${board.report}")
      }

      // Reset with the input in the middle of a frame (the output lags by $rows rows, so none of it is out yet).
      var sentAtReset = 0L
      val (_, none) = stream(dut, Seq(big), Traffic(0.2, 0.2), rnd, choppyBound(Seq(big), p), "mid-frame", Long.MaxValue,
        (_, sent) => { sentAtReset = sent; sent >= w.toLong * h / 2 })
      assert(none.isEmpty, s"mid-frame: ${none.map(_.length).sum} outputs before the reset")
      reset(dut)
      goodAfter(s"reset after $sentAtReset of ${w * h} inputs")

      // Reset with the next frame's input in its middle while the previous frame's output drains.
      var outAtReset = 0L
      val (_, cut) = stream(dut, Seq(big, big), Traffic(0.1, 0.2), rnd, choppyBound(Seq(big, big), p), "mid-frame draining",
        Long.MaxValue, (outs, sent) => { sentAtReset = sent; outAtReset = outs.map(_.length).sum
          sent >= w.toLong * h * 3 / 2 && outAtReset >= w })
      assert(sentAtReset < 2L * w * h && outAtReset < w.toLong * h && cut.length == 1,
        s"mid-frame draining: not mid-frame at the reset ($sentAtReset inputs of ${2 * w * h}, $outAtReset outputs of ${w * h})")
      val prefix = new Scoreboard("top [mid-frame draining, before the reset]")
      check(prefix, big, cut.head, bigExpected, 0, complete = false)
      assert(prefix.ok, prefix.report)
      reset(dut)
      goodAfter(s"reset after $sentAtReset of ${2 * w * h} inputs, $outAtReset of ${w * h} outputs of the first frame")

      // Reset once every input beat is offered while output rows are still to come.
      var drained = 0L
      val (_, drain) = stream(dut, Seq(big), Traffic(0.1, 0.3), rnd, choppyBound(Seq(big), p), "draining", Long.MaxValue,
        (outs, sent) => { drained = outs.map(_.length).sum; sent == w.toLong * h && drained >= w })
      assert(drained <= w.toLong * (h - 1), s"draining: the output was not draining at the reset ($drained of ${w * h})")
      val before = new Scoreboard("top [draining, before the reset]")
      check(before, big, drain.head, bigExpected, 0, complete = false)
      assert(before.ok, before.report)
      reset(dut)
      goodAfter(s"reset with all input in and ${w * h - drained} outputs still to come")
    }
  }
}
