// The remedy for isolated negative radicands in the conservative engines: the few failing components
// take the conventional update, then one rescale psi_k^2 <- psi_k^2 (1 + sum_j c_j w_jk) restores every invariant.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "../compensated_sum.hpp"
#include "../detail/ranges.hpp"
#include "../detail/reduce.hpp"
#include "../detail/simd.hpp"
#include "../detail/state_ops.hpp"
#include "../invariants.hpp"

namespace eci {

/// What a conservative stepper does when some radicands (new psi_k^2) come out negative.
enum class radicand_policy {
    remedy,  ///< isolated failures: conventional update for them, exact rescale of all; else as `halve`
    halve,   ///< fail the step, so the driver halves it: the paper's procedure
};

/// Which finishing pass the conservative RK engines (conservative_rk, and embedded_rk's adaptive pairs) take on a
/// system with declared invariants.
enum class update_kind {
    conditioned,  ///< from remedy_options::min_unknowns real unknowns on: the conditioned update (the default)
    paper,        ///< the paper's per-unknown square root on any system (its bits and its per-unknown remedy)
};

/// Settings of the remedy (docs/methods.md derives each threshold).
struct remedy_options {
    radicand_policy policy = radicand_policy::remedy;  ///< remedy (default) or halve
    /// Paper update (systems below min_unknowns, and C-Euler's and compensated C-PC's remedy), "isolated": the
    /// failing real unknowns are at most this fraction of all, and hold at most this fraction of every invariant's
    /// magnitude sum_k |w_jk| psi_k^2 (before and after the step). On three modes one failure is a third of the
    /// state, so small systems always halve.
    double max_fraction = 0.01;
    /// Conditioned update: the elements given the conventional update hold at most this share of every
    /// invariant's magnitude (before and after the step); no cap on how many they are. (1 % left C-RK4 at up to
    /// 1.9x RK4's error on real n-wave systems, 5 % at 1.2x; docs/methods.md.) The adaptive pairs (embedded_rk)
    /// start from 1, no share cap: their error estimate bounds the conventional elements' error.
    double max_share = 0.05;
    /// The size of the rescale allowed. Paper update (systems below min_unknowns): the largest relative change
    /// |s_k| = |sum_j c_j w_jk| of any psi_k^2, bounded by sum_j |c_j| max_k |w_jk|. Conditioned update: the share
    /// of each invariant the rescale moves, sum_k |w_jk| xi_k |s_k| / sum_k |w_jk| xi_k, with every |s_k| <= 1/2.
    /// Beyond it (a correction that is not small, e.g. from nearly dependent weights) the step is halved instead.
    double max_rescale = 0.01;
    /// The conditioned update (docs/methods.md, "Zero crossings without loss of accuracy") is used by the
    /// conservative RK engine when the invariants' weights are declared, the policy is `remedy` and the state has at
    /// least this many real unknowns and `update` is `conditioned` (the default; `paper` keeps the paper's update and
    /// its bits on any system). Smaller systems (the paper's three-wave model) always take the paper's update.
    std::size_t min_unknowns = 16;
    /// The conditioned update (default) or the paper's update on systems of min_unknowns or more.
    update_kind update = update_kind::conditioned;
    /// kappa of the conditioned update: an element (a real unknown, or a complex mode) whose new xi = |psi|^2 is
    /// below kappa times its change over the step, xi < kappa |xi - |psi(t)|^2|, takes the conventional update
    /// (if the caps allow), since there the square root amplifies the error of xi by 1 / (2 |psi|) and sqrt is
    /// curved across the step; the rescale then restores every invariant. 0 switches it off.
    double condition = 16.0;
    /// A cost setting of the conditioned update at fixed steps, which never changes a result (bit for bit): the
    /// finishing pass files one by one only the ill-conditioned elements whose ratio lies less than this many
    /// buckets (1/32 octave each) above the previous step's cut, and only counts the others; where the share cap
    /// might take a cut among them after all, the pass is made again with every element filed. 0 files every element.
    std::size_t lump_margin = 16;
    /// The conditioned update of the fixed-step engine (conservative_rk) and of the adaptive pairs (embedded_rk) on
    /// real unknowns, for tableaux of order 3 or more: every element takes the conventional update and the exact
    /// rescale restores every invariant (true, the default), or only the ill-conditioned ones by kappa and
    /// max_share (false). The pairs by kappa: c-bs32 at 3.4x bs32's error at rtol 1e-10 on the n-wave system, by
    /// the rescale 0.9x (c-dp54 1.4x and 0.7x). On real unknowns each zero
    /// crossing is a codimension-1 event and the square root's error near it, 1 / (2 |psi|) times xi's, adds up
    /// over the steps near the crossing: with kappa = 16 and the 5 % share C-RK4's error was 2.1-9.5 x RK4's on the
    /// 30-mode n-wave system (dt = 0.01 ... 6.25e-4), 1.3-3.6 x on 1000 modes; by the rescale 0.77-1.08 x
    /// (docs/methods.md). Against a second-order method's error the loss does not show (C-PC 0.97-1.04 x PC's by
    /// kappa, 0.99-1.14 x by the rescale, which costs more): order 2 keeps kappa.
    bool real_by_rescale = true;
    /// The same for complex modes in the fixed-step engine (conservative_rk, tableaux of order 3 or more): every
    /// mode's conventional update and one exact rescale (true, the default), or each mode's modulus update, with
    /// the kappa rule for the ill-conditioned ones (false; the adaptive pairs keep it). The rescale's step is the
    /// conventional method's (C-RK4's error RK4's on turbulence; the modulus update's 0.88-0.96 x), and its pass
    /// takes no square root and files nothing, which on Navier-Stokes costs about half the modulus update's extra
    /// time over RK4 (docs/benchmarks.md, "Session 40").
    bool complex_by_rescale = true;
};

/// What the remedy did so far (a stepper's counters, from the stepper's construction).
struct remedy_stats {
    std::uint64_t remedied_steps = 0;       ///< steps completed by the remedy instead of a halving
    std::uint64_t components_remedied = 0;  ///< real unknowns given the conventional update, summed over steps
    std::uint64_t declined = 0;             ///< steps with failures the remedy left to halving (not isolated,
                                            ///< ill-conditioned, rescale too large, non-finite)
    std::uint64_t conditioned = 0;          ///< of components_remedied, those whose radicand was positive but
                                            ///< whose square root was ill-conditioned (the conditioned update)
    std::uint64_t conditioning_declined = 0;  ///< attempts whose ill-conditioned components kept the conservative
                                              ///< value because the caps (share, rescale) refused them
    std::uint64_t lumped = 0;   ///< ill-conditioned elements only counted by the conditioned pass (lump_margin)
    std::uint64_t refiled = 0;  ///< conditioned passes made again with every element filed (lump_margin)
};

/// The remedy's state: options, weights, counters. Every conservative stepper derives from it, which gives it
/// `remedy` (the options), `set_quadratic_invariants()` and `remedy_statistics()`.
class radicand_remedy {
   public:
    /// Policy and thresholds.
    remedy_options remedy{};

    /// Tells the stepper the invariants it conserves, which the remedy needs (without them it halves). Throws
    /// std::invalid_argument for rows of different sizes, non-finite weights or more than `max_invariants` rows.
    void set_quadratic_invariants(quadratic_weights w) {
        if (w.size() > max_invariants)
            throw std::invalid_argument("at most " + std::to_string(max_invariants) + " quadratic invariants");
        for (const auto& row : w) {
            if (row.size() != w.front().size())
                throw std::invalid_argument("quadratic invariant weights: rows of different sizes");
            for (double v : row)
                if (!std::isfinite(v)) throw std::invalid_argument("quadratic invariant weights must be finite");
        }
        weights_ = std::move(w);
        gram_valid_ = false;
        weights_nonnegative_ = true;
        for (std::size_t j = 0; j < weights_.size(); ++j) {
            wmax_[j] = 0.0;
            wargmax_[j] = 0;
            for (std::size_t e = 0; e < weights_[j].size(); ++e) {
                const double v = weights_[j][e];
                if (std::abs(v) > wmax_[j]) wmax_[j] = std::abs(v), wargmax_[j] = e;
                weights_nonnegative_ = weights_nonnegative_ && v >= 0.0;
            }
        }
    }
    /// The weights in use (empty: none known, the stepper halves).
    const quadratic_weights& quadratic_invariants() const { return weights_; }
    /// Counters since construction.
    const remedy_stats& remedy_statistics() const { return stats_; }

    /// The most invariants the remedy handles (its m x m system lives on the stack).
    static constexpr std::size_t max_invariants = 8;

   protected:
    // Tries to complete a step whose output o (n real unknowns, `per` per state element) has failures. bad(i)
    // says whether unknown i failed; fix(i) returns {conventional update, the conservative radicand} of unknown i.
    // On success o holds the remedied state; rescale_pass(c) then applies psi_k^2 <- psi_k^2 (1 + s_k) (plain
    // steppers call rescale() below; compensated C-PC carries its residual through it). On failure o is garbage.
    template <std::size_t Per, class Bad, class Fix, class Rescale>
    bool try_remedy(double* o, const double* x, std::size_t n, Bad&& bad, Fix&& fix, Rescale&& rescale_pass) {
        const std::size_t m = weights_.size();
        bad_.clear();
        if (remedy.policy != radicand_policy::remedy || m == 0 || weights_.front().size() * Per != n) return false;
        constexpr std::size_t shift = Per == 2 ? 1 : 0;
        double limit = remedy.max_fraction * double(n);
        for (std::size_t i = 0; i < n; ++i) {
            if (!bad(i)) continue;
            bad_.push_back(i);
            // (a state spread over processes decides on the count over all of them, below)
            if (!reduce_ && double(bad_.size()) > limit) return decline();
        }
        // The conventional update for the failing components, and the defect it makes in each invariant.
        std::array<double, max_invariants> defect{}, held{};
        bool finite = true;
        for (std::size_t i : bad_) {
            const auto [conv, rad] = fix(i);
            if (!std::isfinite(conv) || !std::isfinite(rad)) {
                if (!reduce_) return decline();
                finite = false;
                break;
            }
            o[i] = conv;
            const double d = conv * conv - rad, h = std::max(x[i] * x[i], conv * conv);
            for (std::size_t j = 0; j < m; ++j) {
                const double w = weights_[j][i >> shift];
                defect[j] += w * d;
                held[j] += std::abs(w) * h;
            }
        }
        std::size_t failures = bad_.size();
        std::array<double, max_invariants> wmax = wmax_;
        if (reduce_) {
            // Over every process, in one collective each (every process reaches them: the decision to try the
            // remedy was global): the counts, the defects and held shares, the largest weights.
            double count = double(failures), size = double(n), non_finite = finite ? 0.0 : 1.0;
            reduce_.sum_all(count, size, non_finite, std::span(defect.data(), m), std::span(held.data(), m));
            reduce_.max({wmax.data(), m});
            failures = std::size_t(count);
            limit = remedy.max_fraction * size;
            if (non_finite != 0.0 || double(failures) > limit) return decline();
        }
        if (failures == 0) return decline();
        // The Gram matrix G_ij = sum_k w_ik w_jk xi_k and each invariant's magnitude A_j = sum_k |w_jk| xi_k.
        std::array<double, max_invariants * max_invariants> g{};
        std::array<double, max_invariants> mag{};
        gram<shift>(o, n, g, mag);
        reduce_.sum_all(std::span(mag.data(), m), std::span(g));  // g's unused entries are 0
        for (std::size_t j = 0; j < m; ++j)
            if (!(held[j] <= remedy.max_fraction * mag[j])) return decline();
        std::array<double, max_invariants> c{};
        if (!solve(g, mag, defect, c)) return decline();
        // |s_k| <= sum_j |c_j| max_k |w_jk|: a bound, checked before anything is rescaled.
        double s_bound = 0.0;
        for (std::size_t j = 0; j < m; ++j) s_bound += std::abs(c[j]) * wmax[j];
        if (!(s_bound <= remedy.max_rescale)) return decline();
        s_bound_ = s_bound;
        rescale_pass(c);
        ++stats_.remedied_steps;
        stats_.components_remedied += failures;
        return true;
    }

    // The conditioned update's remedy, per element (a real unknown, or a complex mode of Per = 2
    // parts). The engine has filled neg_ (elements whose xi < 0: they must take the conventional update) and cond_
    // (xi >= 0 but an ill-conditioned square root: they take it if the caps allow), and written every element's
    // conservative value into o (the conventional value for neg_). conv(e, c) writes the conventional update of
    // element e into c[0..Per) and returns {sum_p c_p^2, xi_e, sign}: the sign rule's value for a real unknown (the
    // conservative value is sign * sqrt(xi)). The set taken conventional is capped only by the share of every
    // invariant it holds (max_share of sum_k |w_jk| |psi_k|^2, before and after the step) and by the size of the
    // rescale (max_rescale), never by a count. It is the worst-conditioned elements (smallest xi / |change of xi|,
    // by the buckets of the histogram the finishing pass filled): the most of them whose shares pass the cap by the
    // histogram's sums. If the attempt is refused, the most of them under a quarter of that count, and so on down to
    // neg_ alone (cond_ keeping its conservative values); if that is refused too, false (the step fails, is halved).
    template <std::size_t Per, class Conv>
    bool remedy_elements(double* o, const double* x, std::size_t n, Conv&& conv) {
        constexpr std::size_t shift = Per == 2 ? 1 : 0;
        // The Gram sums of the finished state: from the finishing pass (two invariants), else one pass here. Each
        // attempt corrects them for the elements it changes, so no attempt passes over the state for them.
        if (!gram_valid_) {
            g0_ = {}, mag0_ = {};
            gram_compensated<shift>(o, n, g0_, mag0_);
        }
        gram_valid_ = false;  // the next step's finishing pass sets them again
        const std::size_t m = weights_.size(), stride = hist_stride();
        // neg_'s share of each invariant (h = max(|x_e|^2, |c_e|^2)), their count and whether their updates are finite
        std::array<double, max_invariants> held_neg{};
        for (std::size_t k = 0; k < neg_.size(); ++k)
            for (std::size_t a = 0; a < m; ++a) held_neg[a] += std::abs(weights_[a][neg_[k]]) * neg_h_[k];
        double negatives = double(neg_.size());
        double non_finite = finite_updates<Per>(o) ? 0.0 : 1.0;
        // A state spread over processes: every sum and count below is over all of them (one collective each,
        // every process reaching them), so that each process takes the same cut and solves the same system.
        set_whole(n / Per, std::span(g0_), std::span(mag0_.data(), m), std::span(held_neg.data(), m), negatives,
                  non_finite);  // g0_'s unused entries are 0
        reduce_.sum(hist_);
        const bool negatives_finite = non_finite == 0.0;
        // Negative radicands must be taken: if they alone hold too large a share, or are not finite (a step far
        // too large), every set fails; decline at once rather than try the cascade (a step of 1e7 on n-wave would
        // otherwise try it in each of 2^16 attempts).
        if (negatives > 0.0) {
            if (!negatives_finite) return decline();
            for (std::size_t a = 0; a < m; ++a)
                if (!(held_neg[a] <= share_ * mag0_[a])) return decline();
        }
        // The histogram's bucket sums, cumulated from the worst bucket up: cut b (take every bucket below b) holds
        // hist_[(b - 1) * stride ...]. The share each cut holds is then known without a pass over its elements.
        for (std::size_t b = 1; b < ratio_buckets; ++b)
            for (std::size_t i = 0; i < stride; ++i) hist_[b * stride + i] += hist_[(b - 1) * stride + i];
        const std::size_t filed = std::size_t(hist_[(ratio_buckets - 1) * stride]);  // cond_'s size, over all
        if (!lumping_decides(held_neg)) {  // a cut above lump_from_ might pass: the engine files the pass in full
            refile_ = true;
            ++stats_.refiled;
            return false;
        }
        stats_.lumped += std::uint64_t(hist_[lumped_bucket()]);
        for (std::size_t limit = filed;;) {
            const std::size_t cut = widest_cut(limit, held_neg);
            const std::size_t count = cut == 0 ? 0 : std::size_t(hist_[(cut - 1) * stride]);
            if (attempt_elements<Per>(o, x, n, conv, cut, count)) return true;
            ++stats_.conditioning_declined;
            if (count == 0) break;
            limit = count / 4;
            if (limit == 0 && negatives == 0.0) {  // every radicand positive: the conservative update stands
                settle_filed<Per>(o, conv, 0);
                return true;
            }
        }
        --stats_.conditioning_declined;  // the last refusal (no ill-conditioned element taken) is a decline
        return decline();
    }

    // Whether the histogram of a pass that lumped the elements at and above bucket lump_from_ (file_element) gives
    // the decisions of a full one: true when no cut wider than lump_from_ can pass the share cap of some invariant,
    // so that widest_cut, scanning down from the widest, skips every such cut in either histogram and meets the same
    // sums below (the buckets below lump_from_ hold the same elements in the same order). A wider cut c holds at
    // least the share of cut lump_from_ (sums of terms >= 0 only grow, rounding included) and changes the magnitude
    // by at most cut lump_from_'s change plus the lumped elements' |changes|; the 2^-20 margins cover the roundings
    // of those sums in any order (n eps for n below 2^30).
    bool lumping_decides(const std::array<double, max_invariants>& held_neg) const {
        const std::size_t m = weights_.size(), stride = hist_stride();
        const double* lump = hist_.data() + lumped_bucket();
        if (lump[0] == 0.0) return true;
        const double* h = hist_.data() + (lump_from_ - 1) * stride;  // cut lump_from_: every bucket below it
        for (std::size_t a = 0; a < m; ++a) {
            const double change = h[1 + m + a] + lump[1 + m + a] * (1.0 + 0x1p-20) +
                                  0x1p-20 * (std::abs(h[1 + m + a]) + std::abs(mag0_[a]));
            if (!(held_neg[a] + h[1 + a] <= share_ * (mag0_[a] + change))) return true;
        }
        return false;
    }

    /// Whether the last remedy_elements refused only because the pass lumped elements a cut might take
    /// (lumping_decides): the engine then makes the pass again with begin_conditioned(..., lump = false).
    bool refiling() const { return refile_; }

    // The widest cut (cond_'s elements in buckets below it) holding at most `limit` elements whose shares, with
    // neg_'s, pass the share cap by the histogram's sums; 0 (neg_ alone) if none does. The sums are the attempt's
    // own in another order: the attempt checks the cap again from its exact sums.
    std::size_t widest_cut(std::size_t limit, const std::array<double, max_invariants>& held_neg) const {
        const std::size_t m = weights_.size(), stride = hist_stride();
        for (std::size_t cut = ratio_buckets; cut > 0; --cut) {
            const double* h = hist_.data() + (cut - 1) * stride;
            if (h[0] == 0.0) return 0;  // no element in any bucket below
            if (cut > 1 && h[0] == h[-std::ptrdiff_t(stride)]) continue;  // bucket cut - 1 is empty: the same set
            if (h[0] > double(limit)) continue;
            bool holds = true;
            for (std::size_t a = 0; holds && a < m; ++a)
                holds = held_neg[a] + h[1 + a] <= share_ * (mag0_[a] + h[1 + m + a]);
            if (holds) return cut;
        }
        return 0;
    }

    // The conditioned update's finishing pass, shared by the conservative engines (conservative_rk,
    // embedded_rk): begin_conditioned(elements), then condition_element() for every element in order, then
    // end_conditioned(); remedy_elements() then decides. The engine computes each element's conventional update c
    // (Per parts), |c|^2 and xi = the tableau applied to |psi_e|^2; condition_element writes the element's value
    // into o and files it: a real unknown sgn * sqrt(xi) (sign: the engine's sign rule), a complex mode the
    // conventional update rescaled to modulus sqrt(xi), so its phase is the conventional method's and it is near
    // zero only where both parts are (codimension 2). Elements with xi < 0 go to neg_ (o holds their conventional
    // update), those with xi < kappa |xi - |psi(t)|^2| to cond_ (o holds the conservative value).
    struct conditioned_pass {
        // The Gram sums of the finished state, G_ab = sum_e w_ae w_be |o_e|^2 and A_a = sum_e |w_ae| |o_e|^2, are
        // accumulated in the finishing pass when there are two invariants (E and Z: every spectral model, n-wave),
        // so that the remedy needs no pass of its own over the state (docs/methods.md, "Cost"). G is summed with
        // compensation (error-free additions): where E and Z are nearly dependent (a Taylor-Green flow and a small
        // perturbation) the rescale's coefficients are large and of opposite signs, and plain sums, which drop
        // every small term added after the large ones, erred by up to 160 eps in G_00, one-signed: C-PC drifted E
        // by ~5 eps per step (50 eps sqrt(n) at N = 128; docs/methods.md).
        compensated_sum g00, g01, g11;
        double a0 = 0.0, a1 = 0.0;
        const double* w0 = nullptr;  // the two invariants' weights (null: not fused)
        const double* w1 = nullptr;
    };

    /// What an engine's conv(e, c) returns to remedy_elements besides the conventional update c of element e:
    /// |c|^2, xi (the tableau applied to |psi_e|^2) and the sign rule's value for a real unknown.
    struct element_update {
        double c2, xi, sign;
    };

    /// What condition_element made of an element.
    enum class element_kind {
        conservative,  ///< the conservative value (possibly filed in cond_: the remedy may yet take it conventional)
        conventional,  ///< the conventional update (filed in neg_, or a complex mode with no phase staying at zero)
    };

    // predict: the engine reads nothing of o before remedy_elements, so the finishing pass may write the
    // conventional update of the filed elements the previous step's cut took (see written_cut_).
    // ranges: how many ranges the engine files the elements in (conservative_rk splits its pass over the model's
    // threads): range 0 files into neg_, cond_ and hist_, range r > 0 into parts_[r - 1] (range_filing), and
    // end_split_conditioned merges them.
    // lump: elements filed at or above a bucket the previous step's cut predicts the share cap never reaches
    // (lump_from_) are only counted (file_element), which on turbulence skips most of the filing; remedy_elements
    // asks for the pass again without (refiling) where the sums cannot show the cut stays below.
    // every_element: the engines' passes over real unknowns with remedy.real_by_rescale; every element
    // that changes is filed as ill-conditioned (kappa infinite, the 2^-40 agreement ignored) and the share cap is 1,
    // so that the step is the conventional update and the exact rescale (remedy_options::real_by_rescale).
    conditioned_pass begin_conditioned(std::size_t elements, bool predict = false, int ranges = 1, bool lump = false,
                                       bool every_element = false) {
        kappa_ = every_element ? HUGE_VAL : remedy.condition;
        agree_ = every_element ? 0.0 : 0x1p-40;
        share_ = every_element ? 1.0 : remedy.max_share;
        neg_.clear();
        neg_h_.clear();
        cond_.clear();
        if (parts_.size() < std::size_t(ranges - 1)) parts_.resize(std::size_t(ranges - 1));
        for (filing_part& part : parts_) part.neg.clear(), part.neg_h.clear(), part.cond.clear(), part.filed = false;
        parts_used_ = std::size_t(ranges - 1);
        // room for every element at once: pages the filing never reaches are never touched (not resident), and
        // no reallocation copies a half-filed list (which held 1.5 lists at its peak)
        if (cond_.capacity() < elements) cond_.reserve(elements);
        written_cut_ = predict && weights_fused() ? taken_cut_ : 0;
        lump_from_ = lump && taken_cut_ > 0 && remedy.lump_margin > 0
                         ? std::min(taken_cut_ + std::min(remedy.lump_margin, ratio_buckets), ratio_buckets)
                         : ratio_buckets;
        taken_cut_ = 0;
        refile_ = false;
        hist_.assign((ratio_buckets + 1) * hist_stride(), 0.0);  // (the last: the lumped elements' sums)
        return fused_pass();
    }

    void end_conditioned(const conditioned_pass& p) {
        if (p.w0) set_gram(p);
    }

    // Where a conditioned pass files its elements: the stepper's own lists (an unsplit pass, and range 0 of a split
    // one), or a part of its own for each further range of a split pass, so that the ranges file concurrently.
    struct filing {
        std::vector<std::size_t>& neg;
        std::vector<double>& neg_h;
        std::vector<std::uint64_t>& cond;
        double* hist;
    };
    filing own_filing() { return {neg_, neg_h_, cond_, hist_.data()}; }

    // Range r's filing of a pass begun with begin_conditioned(elements, predict, ranges), for its elements
    // e0 .. e1 - 1 (called on the range's thread: the part's lists grow to the range's share at most, and its
    // histogram starts from zero here, in parallel).
    filing range_filing(int r, std::size_t e0, std::size_t e1) {
        if (r == 0) return own_filing();
        filing_part& part = parts_[std::size_t(r - 1)];
        if (part.cond.capacity() < e1 - e0) part.cond.reserve(e1 - e0);
        part.hist.assign(hist_.size(), 0.0);
        part.filed = true;
        return {part.neg, part.neg_h, part.cond, part.hist.data()};
    }

    // After a split pass whose range r ended with Gram sums passes[r]: the ranges' negative elements appended to
    // neg_ in range order (so in element order, as an unsplit pass files them), their histograms and Gram sums
    // added to range 0's in range order (the compensated sums with their error terms). cond_ stays in parts
    // (settle_filed reads them in range order), so the filing is held once, not twice. For one range:
    // end_conditioned(passes[0]).
    void end_split_conditioned(std::span<conditioned_pass> passes) {
        conditioned_pass total = passes[0];
        for (std::size_t r = 1; r < passes.size(); ++r) {
            filing_part& part = parts_[r - 1];
            if (!part.filed) continue;  // (the model ran fewer ranges)
            neg_.insert(neg_.end(), part.neg.begin(), part.neg.end());
            neg_h_.insert(neg_h_.end(), part.neg_h.begin(), part.neg_h.end());
            for (std::size_t i = 0; i < hist_.size(); ++i) hist_[i] += part.hist[i];
            merge_gram(total, passes[r]);
        }
        end_conditioned(total);
    }

    // Range p's Gram sums added to `total` (the compensated sums with their error terms), as a split pass merges
    // its ranges in range order.
    static void merge_gram(conditioned_pass& total, const conditioned_pass& p) {
        const auto merge = [](compensated_sum& sum, const compensated_sum& range_sum) {
            sum.add(range_sum.s);
            sum.err += range_sum.err;
        };
        merge(total.g00, p.g00), merge(total.g01, p.g01), merge(total.g11, p.g11);
        total.a0 += p.a0, total.a1 += p.a1;
    }

    // The sums a rescale finish starts from (rescale_conventional): the Gram sums fused when there are two
    // invariants.
    conditioned_pass begin_rescale() const { return fused_pass(); }

    // Whether the last conditioned pass filed no element (neg_ and every range's cond_ empty).
    bool filed_none() const {
        if (!(neg_.empty() && cond_.empty()) || hist_[lumped_bucket()] != 0.0) return false;
        for (std::size_t r = 0; r < parts_used_; ++r)
            if (!parts_[r].cond.empty()) return false;
        return true;
    }

    // The rescale finish (remedy_options::real_by_rescale, complex_by_rescale): the engine wrote every element's
    // conventional update c_e into o and summed, in the same pass, each invariant's defect
    // defect_j = sum_e w_je (|c_e|^2 - xi_e) (xi_e: the tableau applied to |psi_e|^2, whose weighted sums are what
    // the conservative method gives each invariant) and, with two invariants, the Gram sums of |c_e|^2 in `sums`
    // (begin_rescale's; null weights: none summed, one pass here). One exact rescale then restores every
    // invariant: the new state is the conventional method's, moved by a relative ~defect / invariant, and the
    // invariants the conservative method's. No element is filed and no square root taken. false: refused (a sum not
    // finite, or the rescale too large): o holds the conventional update, and the engine takes the conditioned
    // update (remedy_elements) instead. negatives: the elements with xi_e < 0 (counted apart in the statistics).
    template <std::size_t Per>
    bool rescale_conventional(double* o, std::size_t n, const conditioned_pass& sums,
                              std::array<double, max_invariants> defect, double negatives) {
        constexpr std::size_t shift = Per == 2 ? 1 : 0;
        const std::size_t m = weights_.size();
        gram_sums g{};
        invariant_sums mag{};
        if (sums.w0)
            gram_of(sums, g, mag);
        else
            gram_compensated<shift>(o, n, g, mag);
        // over every process, in one collective: each takes the same decision and the same rescale
        set_whole(n / Per, std::span(g), std::span(mag.data(), m), std::span(defect.data(), m), negatives);
        bool finite = true;
        for (std::size_t a = 0; a < m; ++a) {
            finite = finite && std::isfinite(defect[a]) && std::isfinite(mag[a]);
            for (std::size_t b = 0; b < m; ++b) finite = finite && std::isfinite(g[a * max_invariants + b]);
        }
        if (!finite || !rescale_exactly<Per>(o, n, g, mag, defect, true)) return false;
        ++stats_.remedied_steps;
        stats_.components_remedied += whole_.elements * Per;
        stats_.conditioned += (whole_.elements - std::size_t(negatives)) * Per;
        return true;
    }

    template <std::size_t Per>
    element_kind condition_element(double* o, const double* x, std::size_t e, const std::array<double, Per>& c,
                                   double c2, double xi, double sign, conditioned_pass& pass) {
        double q = 0.0;
        const element_kind kind = condition_unsummed<Per>(o, x, e, c, c2, xi, sign, q, own_filing());
        gram_add(pass, e, q);
        return kind;
    }

    // condition_element without the Gram sums: |o_e|^2 of the value o_e ends with into q (condition_block sums a
    // block's elements after filing them, in element order).
    template <std::size_t Per>
    element_kind condition_unsummed(double* o, const double* x, std::size_t e, const std::array<double, Per>& c,
                                    double c2, double xi, double sign, double& q, const filing& into) {
        const double kappa = kappa_;
        double x2 = 0.0;
        for (std::size_t p = 0; p < Per; ++p) {
            o[e * Per + p] = c[p];
            x2 += x[e * Per + p] * x[e * Per + p];
        }
        q = c2;  // |o_e|^2 of the value o_e ends with (the conventional one unless changed below)
        element_kind kind = element_kind::conservative;
        if (!(xi >= 0.0)) {
            into.neg.push_back(e);
            into.neg_h.push_back(std::max(x2, c2));
            kind = element_kind::conventional;
        } else {
            if (Per == 2 && !(c2 > 0.0)) {  // no phase to give it: a mode that stays at zero, or a conventional zero
                if (xi > 0.0) into.neg.push_back(e), into.neg_h.push_back(std::max(x2, c2));
                kind = element_kind::conventional;
            } else {
                q = conservative_value<Per>(o + e * Per, c, c2, xi, sign);
            }
            // Ill-conditioned, and the conventional update differs from it beyond round-off (2^-40 relative):
            // where the two agree to a few ulps the swap gains nothing, and its defect (then of the order of eps
            // times their share of each invariant, and of one sign from step to step) would be too small for
            // the rescale to represent: a systematic drift of ~eps per step (measured on DP54 at small steps,
            // 15 eps sqrt(n)).
            const double change = std::abs(xi - x2);
            if (kind == element_kind::conservative && xi < kappa * change &&
                std::abs(c2 - xi) > agree_ * std::max(c2, xi)) {
                file_element<Per>(o, e, ratio_bucket(xi / change), c.data(), std::max(x2, c2), c2 - q, c2 - xi, into);
            }
        }
        return kind;
    }

    // Files element e (conventional update c) in cond_ with bucket b, and what taking it changes into the bucket's
    // sums: its count, share weight h, change dq of |o_e|^2 and defect d, weighed (attempt_elements reads a cut's
    // sums, never its elements). An element the previous step's cut predicts taken gets its conventional update.
    template <std::size_t Per>
    [[gnu::always_inline]] void file_element(double* o, std::size_t e, std::size_t b, const double* c, double h,
                                             double dq, double d, const filing& into) {
        const std::size_t m = weights_.size();
        if (b >= lump_from_) {  // beyond the predicted cut: counted, with its |change| of each magnitude
            double* hl = into.hist + lumped_bucket();
            hl[0] += 1.0;
            for (std::size_t a = 0; a < m; ++a) hl[1 + m + a] += std::abs(weights_[a][e]) * std::abs(dq);
            return;
        }
        into.cond.push_back((std::uint64_t(e) << bucket_bits) | b);
        double* hb = into.hist + b * hist_stride();
        hb[0] += 1.0;
        if (m == 2) {  // E and Z (every spectral model): the loop below unrolled, its operations in its order
            const double u = weights_[0][e], v = weights_[1][e], au = std::abs(u), av = std::abs(v);
            hb[1] += au * h, hb[2] += av * h, hb[3] += au * dq, hb[4] += av * dq, hb[5] += u * d, hb[6] += v * d;
            hb[7] += u * u * dq, hb[8] += u * v * dq, hb[9] += v * u * dq, hb[10] += v * v * dq;
            const bool take = b < written_cut_;  // (a select, not a branch: as good as random on turbulence)
            for (std::size_t p = 0; p < Per; ++p) o[e * Per + p] = take ? c[p] : o[e * Per + p];
            return;
        }
        for (std::size_t a = 0; a < m; ++a) {
            const double w = weights_[a][e], aw = std::abs(w);
            hb[1 + a] += aw * h, hb[1 + m + a] += aw * dq, hb[1 + 2 * m + a] += w * d;
            for (std::size_t bb = 0; bb < m; ++bb) hb[1 + 3 * m + a * m + bb] += w * weights_[bb][e] * dq;
        }
        if (b < written_cut_)  // (|o_e|^2 in the Gram sums stays the conservative value's)
            for (std::size_t p = 0; p < Per; ++p) o[e * Per + p] = c[p];
    }

    /// Elements per block of condition_block.
    static constexpr std::size_t block_elements = 64;  // (at most 256: condition_block lists them in bytes)

    /// condition_element for the elements e0 .. e0 + nb (nb <= block_elements) at once, with the same result to
    /// the bit: c holds their conventional updates (nb * Per values), c2, xi and sign one value per element. The
    /// common element (xi >= 0, a well-conditioned square root, a complex mode whose moduli differ beyond 2^-46)
    /// takes its conservative value in a loop the compiler vectorizes; the others go through condition_element.
    template <std::size_t Per>
    void condition_block(double* o, const double* x, std::size_t e0, std::size_t nb, const double* c,
                         const double* c2, const double* xi, const double* sign, conditioned_pass& pass,
                         const filing& into) {
        const double kappa = kappa_;
        std::array<double, block_elements> q, x2v, ratio;
        std::array<unsigned char, block_elements> kind;  // 0 plain, 1 plain and filed, 2 special
        double* ob = o + e0 * Per;
        const double* xb = x + e0 * Per;
        if constexpr (Per == 2) {  // complex modes (every spectral model): explicitly vectorized, the same bits
            detail::condition_moduli(ob, q.data(), x2v.data(), ratio.data(), kind.data(), xb, c, c2, xi, kappa, nb);
        } else {  // real unknowns (Per = 1): the compiler vectorizes this loop
            for (std::size_t b = 0; b < nb; ++b) {
                const double x2 = xb[b] * xb[b];
                const double v = xi[b], change = std::abs(v - x2);
                const bool plain = v >= 0.0;
                const bool filed = v < kappa * change && std::abs(c2[b] - v) > agree_ * std::max(c2[b], v);
                kind[b] = plain ? (filed ? 1 : 0) : 2;
                ratio[b] = v / change;  // (its bucket is taken for the filed elements alone, below)
                x2v[b] = x2;
                ob[b] = std::copysign(std::sqrt(v), sign[b]);
                q[b] = ob[b] * ob[b];
            }
        }
        // the filing, in element order. Which elements are filed is as good as random on turbulence (two thirds of
        // them at CFL 0.5), so a branch per element mispredicts about every other time: the filed and the lumped
        // (at or above lump_from_, see file_element) are first listed without branches. A block with a special
        // element (kind 2, rare) is filed element by element, so that every element is filed in element order.
        const double lump_edge = lump_from_ < ratio_buckets ? bucket_edge(lump_from_) : HUGE_VAL;
        std::array<unsigned char, block_elements> filed_list, lumped_list;
        std::size_t nf = 0, nl = 0, special = 0;
        for (std::size_t b = 0; b < nb; ++b) {
            const bool is_filed = kind[b] == 1, lump = ratio[b] >= lump_edge;
            filed_list[nf] = (unsigned char)b, lumped_list[nl] = (unsigned char)b;
            nf += is_filed && !lump, nl += is_filed && lump, special += kind[b] == 2;
        }
        if (special != 0) {
            for (std::size_t b = 0; b < nb; ++b) {
                if (kind[b] == 0) continue;
                if (kind[b] == 2) {
                    std::array<double, Per> cb;
                    for (std::size_t p = 0; p < Per; ++p) cb[p] = c[b * Per + p];
                    condition_unsummed<Per>(o, x, e0 + b, cb, c2[b], xi[b], sign[b], q[b], into);
                    continue;
                }
                file_element<Per>(o, e0 + b, ratio_bucket(ratio[b]), c + b * Per, std::max(x2v[b], c2[b]),
                                  c2[b] - q[b], c2[b] - xi[b], into);
            }
        } else {
            for (std::size_t j = 0; j < nf; ++j) {
                const std::size_t b = filed_list[j];
                file_element<Per>(o, e0 + b, ratio_bucket(ratio[b]), c + b * Per, std::max(x2v[b], c2[b]),
                                  c2[b] - q[b], c2[b] - xi[b], into);
            }
            if (nl != 0) {  // summed here in registers, not through the one bucket they share in memory
                const std::size_t m = weights_.size();
                std::array<double, max_invariants> change{};
                for (std::size_t j = 0; j < nl; ++j) {
                    const std::size_t b = lumped_list[j];
                    const double dq = std::abs(c2[b] - q[b]);
                    for (std::size_t a = 0; a < m; ++a) change[a] += std::abs(weights_[a][e0 + b]) * dq;
                }
                double* hl = into.hist + lumped_bucket();
                hl[0] += double(nl);
                for (std::size_t a = 0; a < m; ++a) hl[1 + m + a] += change[a];
            }
        }
        gram_block(pass, e0, q.data(), nb);
    }

    // gram_add for elements e0 .. e0 + nb, |o_e|^2 in q, with the same operations in the same order (so the same
    // bits): G_00 and G_01 summed side by side in the two lanes of one SSE2 vector, which halves the additions of the
    // three error-free sums that are most of a fused pass's Gram cost.
    static void gram_block(conditioned_pass& pass, std::size_t e0, const double* q, std::size_t nb) {
        if (!pass.w0) return;
#if ECI_DETAIL_X86_SIMD
        if (detail::cpu_has_avx2()) {
            std::array<double, 3> none;
            return defect_gram_block_avx2<false>(pass, e0, q, nullptr, nb, none);
        }
        const double* w0 = pass.w0 + e0;
        const double* w1 = pass.w1 + e0;
        __m128d s = _mm_set_pd(pass.g01.s, pass.g00.s), err = _mm_set_pd(pass.g01.err, pass.g00.err);
        compensated_sum g11 = pass.g11;
        double a0 = pass.a0, a1 = pass.a1;
        for (std::size_t b = 0; b < nb; ++b) {
            const double u = w0[b], v = w1[b], qb = q[b];
            const __m128d val = _mm_mul_pd(_mm_mul_pd(_mm_set1_pd(u), _mm_set_pd(v, u)), _mm_set1_pd(qb));
            const __m128d t = _mm_add_pd(s, val), z = _mm_sub_pd(t, s);  // compensated_sum::add, lane by lane
            err = _mm_add_pd(err, _mm_add_pd(_mm_sub_pd(s, _mm_sub_pd(t, z)), _mm_sub_pd(val, z)));
            s = t;
            g11.add(v * v * qb);
            a0 += std::abs(u) * qb, a1 += std::abs(v) * qb;
        }
        pass.g00.s = _mm_cvtsd_f64(s), pass.g01.s = _mm_cvtsd_f64(_mm_unpackhi_pd(s, s));
        pass.g00.err = _mm_cvtsd_f64(err), pass.g01.err = _mm_cvtsd_f64(_mm_unpackhi_pd(err, err));
        pass.g11 = g11, pass.a0 = a0, pass.a1 = a1;
#else
        for (std::size_t b = 0; b < nb; ++b) gram_add(pass, e0 + b, q[b]);
#endif
    }

    // A rescale finish's sums over the elements e0 .. e0 + nb with two invariants (pass fused), |c_e|^2 in c2 and
    // xi_e in xi: the defects d_j = sum_b w_jb (c2_b - xi_b), summed from zero (the caller adds them to its range's),
    // the negative xi_b counted (d[2]), and c2 into the Gram sums as gram_block adds them. The AVX2 version takes
    // every sum in a lane of its own, term by term in element order with the same operations: the same bits.
    static void defect_gram_block(conditioned_pass& pass, std::size_t e0, const double* c2, const double* xi,
                                  std::size_t nb, std::array<double, 3>& d) {
#if ECI_DETAIL_X86_SIMD
        if (detail::cpu_has_avx2()) return defect_gram_block_avx2<true>(pass, e0, c2, xi, nb, d);
#endif
        const double* w0 = pass.w0 + e0;
        const double* w1 = pass.w1 + e0;
        double d0 = 0.0, d1 = 0.0, neg = 0.0;
        for (std::size_t b = 0; b < nb; ++b) {
            const double v = c2[b] - xi[b];
            d0 += w0[b] * v, d1 += w1[b] * v, neg += xi[b] < 0.0 ? 1.0 : 0.0;
        }
        d = {d0, d1, neg};
        gram_block(pass, e0, c2, nb);
    }
#if ECI_DETAIL_X86_SIMD
    // compensated_sum::add in each lane
    [[gnu::always_inline]] __attribute__((target("avx2"))) static void add_compensated(__m256d& s, __m256d& err,
                                                                                       __m256d val) {
        const __m256d t = _mm256_add_pd(s, val), z = _mm256_sub_pd(t, s);
        err = _mm256_add_pd(err, _mm256_add_pd(_mm256_sub_pd(s, _mm256_sub_pd(t, z)), _mm256_sub_pd(val, z)));
        s = t;
    }
    // r_i's lane j <- r_j's lane i
    [[gnu::always_inline]] __attribute__((target("avx2"))) static void transpose(__m256d& r0, __m256d& r1,
                                                                                 __m256d& r2, __m256d& r3) {
        const __m256d lo01 = _mm256_unpacklo_pd(r0, r1), hi01 = _mm256_unpackhi_pd(r0, r1);
        const __m256d lo23 = _mm256_unpacklo_pd(r2, r3), hi23 = _mm256_unpackhi_pd(r2, r3);
        r0 = _mm256_permute2f128_pd(lo01, lo23, 0x20), r1 = _mm256_permute2f128_pd(hi01, hi23, 0x20);
        r2 = _mm256_permute2f128_pd(lo01, lo23, 0x31), r3 = _mm256_permute2f128_pd(hi01, hi23, 0x31);
    }
    // Lanes: (d_0, d_1, A_0, A_1), each a plain sum, and (G_00, G_01, G_11, unused) summed with compensation.
    // Defects false: gram_block's sums alone (xi unread, d untouched).
    template <bool Defects>
    __attribute__((target("avx2"))) static void defect_gram_block_avx2(conditioned_pass& pass, std::size_t e0,
                                                                       const double* c2, const double* xi,
                                                                       std::size_t nb, std::array<double, 3>& d) {
        const double* w0 = pass.w0 + e0;
        const double* w1 = pass.w1 + e0;
        __m256d lin = _mm256_set_pd(pass.a1, pass.a0, 0.0, 0.0);
        __m256d s = _mm256_set_pd(0.0, pass.g11.s, pass.g01.s, pass.g00.s);
        __m256d err = _mm256_set_pd(0.0, pass.g11.err, pass.g01.err, pass.g00.err);
        double neg = 0.0;
        // The sums' additions are in element order; their terms are not: four elements' terms at a time, formed
        // across the elements and transposed into one vector per element.
        const __m256d magnitude = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffff));
        std::size_t b = 0;
        for (; b + 4 <= nb; b += 4) {
            const __m256d u = _mm256_loadu_pd(w0 + b), v = _mm256_loadu_pd(w1 + b), q = _mm256_loadu_pd(c2 + b);
            const __m256d x = Defects ? _mm256_loadu_pd(xi + b) : _mm256_setzero_pd(), dv = _mm256_sub_pd(q, x);
            __m256d l0 = Defects ? _mm256_mul_pd(u, dv) : x, l1 = Defects ? _mm256_mul_pd(v, dv) : x;
            __m256d l2 = _mm256_mul_pd(_mm256_and_pd(u, magnitude), q);
            __m256d l3 = _mm256_mul_pd(_mm256_and_pd(v, magnitude), q);
            __m256d g0 = _mm256_mul_pd(_mm256_mul_pd(u, u), q), g1 = _mm256_mul_pd(_mm256_mul_pd(u, v), q);
            __m256d g2 = _mm256_mul_pd(_mm256_mul_pd(v, v), q), g3 = _mm256_setzero_pd();
            transpose(l0, l1, l2, l3);
            transpose(g0, g1, g2, g3);
            lin = _mm256_add_pd(lin, l0), add_compensated(s, err, g0);
            lin = _mm256_add_pd(lin, l1), add_compensated(s, err, g1);
            lin = _mm256_add_pd(lin, l2), add_compensated(s, err, g2);
            lin = _mm256_add_pd(lin, l3), add_compensated(s, err, g3);
            if constexpr (Defects)
                neg += double(__builtin_popcount(
                    unsigned(_mm256_movemask_pd(_mm256_cmp_pd(x, _mm256_setzero_pd(), _CMP_LT_OQ)))));
        }
        for (; b < nb; ++b) {
            const double u = w0[b], v = w1[b], q = c2[b], dv = Defects ? c2[b] - xi[b] : 0.0;
            // d_0 += u dv, d_1 += v dv, A_0 += |u| q, A_1 += |v| q
            lin = _mm256_add_pd(lin, _mm256_mul_pd(_mm256_set_pd(std::abs(v), std::abs(u), v, u),
                                                   _mm256_set_pd(q, q, dv, dv)));
            // G_00 += u u q, G_01 += u v q, G_11 += v v q (compensated_sum::add, lane by lane)
            const __m256d uv = _mm256_mul_pd(_mm256_set_pd(0.0, v, u, u), _mm256_set_pd(0.0, v, v, u));
            add_compensated(s, err, _mm256_mul_pd(uv, _mm256_set1_pd(q)));
            if constexpr (Defects) neg += xi[b] < 0.0 ? 1.0 : 0.0;
        }
        alignas(32) double l[4], sv[4], ev[4];
        _mm256_store_pd(l, lin), _mm256_store_pd(sv, s), _mm256_store_pd(ev, err);
        if constexpr (Defects) d = {l[0], l[1], neg};
        pass.a0 = l[2], pass.a1 = l[3];
        pass.g00 = {sv[0], ev[0]}, pass.g01 = {sv[1], ev[1]}, pass.g11 = {sv[2], ev[2]};
    }
#endif

    // An element's |o_e|^2 into the Gram sums of a fused pass, in element order.
    static void gram_add(conditioned_pass& pass, std::size_t e, double q) {
        if (!pass.w0) return;
        const double u = pass.w0[e], v = pass.w1[e];
        pass.g00.add(u * u * q), pass.g01.add(u * v * q), pass.g11.add(v * v * q);
        pass.a0 += std::abs(u) * q, pass.a1 += std::abs(v) * q;
    }

    // An element's conservative value into o_e, returning |o_e|^2: a real unknown sign * sqrt(xi), a complex mode
    // (c2 > 0) the conventional update c rescaled to modulus sqrt(xi). The finishing pass and settle_filed
    // (remedy_elements) form it alike, to the same bits.
    template <std::size_t Per>
    static double conservative_value(double* oe, const std::array<double, Per>& c, double c2, double xi, double sign) {
        if constexpr (Per == 1) {
            oe[0] = std::copysign(std::sqrt(xi), sign);
            return oe[0] * oe[0];
        } else {
            (void)sign;
            modulus_update<Per>(oe, c, xi, c2);
            return oe[0] * oe[0] + oe[1] * oe[1];
        }
    }

    // A complex mode's new value: the conventional update c rescaled to modulus sqrt(xi). Where the two moduli
    // agree to within 2^-46 the rescaled value lies within a few ulps of c, and plain rounding would return c
    // itself, |o|^2 = |c|^2 instead of xi, keeping the conventional modulus' offset from xi, which has one sign from
    // step to step (DP54 at small steps drifted E and Z by ~eps / 40 per step, 8 eps sqrt(n) over 10^5 steps). There
    // each part is c_p (1 + g), g = sqrt(xi / |c|^2) - 1 from an error-free |c|^2, rounded stochastically to one of
    // its two neighbouring doubles with a uniform number hashed from xi's and |c_p|'s bits: unbiased, and
    // deterministic (a restart from the same state gives the same bits).
    template <std::size_t Per>
    static void modulus_update(double* o, const std::array<double, Per>& c, double xi, double c2) {
        if (!(std::abs(xi - c2) <= 0x1p-46 * xi)) {
            const double root = std::sqrt(xi), r = std::sqrt(c2);
            for (std::size_t p = 0; p < Per; ++p) o[p] = root * (c[p] / r);
            return;
        }
        double hi = 0.0, lo = 0.0;  // |c|^2 = hi + lo, error-free
        for (std::size_t p = 0; p < Per; ++p) {
            const double sq = c[p] * c[p], sq_err = std::fma(c[p], c[p], -sq);
            const double t = hi + sq, z = t - hi;
            lo += ((hi - (t - z)) + (sq - z)) + sq_err;
            hi = t;
        }
        const double g = ((xi - hi) - lo) / (2.0 * hi);  // xi - hi is exact here (Sterbenz); g ~ 2^-46 at most
        std::uint64_t bits;
        std::memcpy(&bits, &xi, sizeof bits);
        for (std::size_t p = 0; p < Per; ++p) {
            const double mag = std::abs(c[p]);
            std::uint64_t cb;
            std::memcpy(&cb, &mag, sizeof cb);
            o[p] = add_stochastically(c[p], c[p] * g, bits ^ (cb * 0x9E3779B97F4A7C15ull) ^ (p + 1));
        }
    }

    // The double next to a finite v toward +inf (up) or -inf: std::nextafter's value, from v's bits plus or minus
    // one (away from zero or toward it; 0 and -0 step to the smallest subnormal of the sign asked), without the
    // library call that kept the rescale's loop from being inlined (checked equal to std::nextafter bit for bit on
    // 2e7 random doubles and the edge values: subnormals, the largest double, both zeros).
    static double next_toward(double v, bool up) {
        if (v == 0.0) return up ? std::numeric_limits<double>::denorm_min() : -std::numeric_limits<double>::denorm_min();
        std::uint64_t b;
        std::memcpy(&b, &v, sizeof b);
        b = (v > 0.0) == up ? b + 1 : b - 1;
        std::memcpy(&v, &b, sizeof b);
        return v;
    }

    // v + delta rounded to one of the two doubles around it, up with probability its distance from the lower one in
    // ulps: unbiased, where round-to-nearest would return v itself for any |delta| below half an ulp. The uniform
    // number is hashed from the caller's key, made of values (not of an index: mirror-image modes, k and -k of a
    // real field, get mirror-image values; and a restart from the same state gives the same bits). v + delta must
    // be finite.
    static double add_stochastically(double v, double delta, std::uint64_t key) {
        if (delta == 0.0) return v;
        const double next = next_toward(v, delta > 0.0), gap = next - v;
        if (!std::isfinite(gap)) return v + delta;  // (at the largest double)
        const double frac = delta / gap;  // in [0, 1) for |delta| below an ulp, else more
        std::uint64_t h = key;  // splitmix64's finish
        h = (h ^ (h >> 30)) * 0xBF58476D1CE4E5B9ull;
        h = (h ^ (h >> 27)) * 0x94D049BB133111EBull;
        h ^= h >> 31;
        const double u = double(h >> 11) * 0x1.0p-53;
        const double whole = std::floor(frac);  // the ulps delta spans (0 or -1 below an ulp of either sign)
        return v + (whole + (u < frac - whole ? 1.0 : 0.0)) * gap;
    }

    // The last successful remedy_elements gave the conventional update to cond_'s elements in buckets below this.
    std::size_t taken_cut_ = 0;
    // o holds the conventional update of cond_'s elements in buckets below this, their conservative value above:
    // the finishing pass writes the split the previous step's cut predicts (0 unless begin_conditioned was asked
    // to predict), and each attempt moves it to its own cut. Only elements between the two are recomputed, and
    // both values are recomputed to the finishing pass's bits, so o never depends on the prediction.
    std::size_t written_cut_ = 0;
    // The filing of this pass lumps the elements in buckets at or above this (ratio_buckets: none): remedy.lump_margin
    // buckets above the previous step's cut. On turbulence at CFL 0.5 (N = 1024, the bench's field) two thirds of
    // the modes are ill-conditioned, the share cap takes a third of those, the cut moves by at most 3 buckets per
    // step, and 16 buckets above it lump two thirds of the filed elements.
    std::size_t lump_from_ = ratio_buckets;
    // the pass's filing rule (begin_conditioned): kappa, the agreement below which an element is not filed, the
    // share cap
    double kappa_ = 16.0, agree_ = 0x1p-40, share_ = 0.05;
    bool refile_ = false;
    template <std::size_t Per, class Conv>
    void settle_filed(double* o, Conv& conv, std::size_t cut) {
        const std::size_t lo = std::min(cut, written_cut_), hi = std::max(cut, written_cut_);
        written_cut_ = cut;
        if (lo == hi) return;
        const auto settle = [&](const std::vector<std::uint64_t>& filed) {
            for (const std::uint64_t key : filed) {
                const std::size_t b = std::size_t(key & bucket_mask);
                if (b < lo || b >= hi) continue;
                const std::size_t e = std::size_t(key >> bucket_bits);
                std::array<double, Per> c{};
                const auto u = conv(e, c);
                if (b < cut)
                    for (std::size_t p = 0; p < Per; ++p) o[e * Per + p] = c[p];
                else
                    conservative_value<Per>(o + e * Per, c, u.c2, u.xi, u.sign);
            }
        };
        settle(cond_);
        for (std::size_t r = 0; r < parts_used_; ++r) settle(parts_[r].cond);
    }
    // Per bucket of hist_: the count, then for each invariant a: sum |w_a| h, sum |w_a| dq, sum w_a d, then the
    // m x m sums w_a w_b dq.
    std::size_t hist_stride() const {
        const std::size_t m = weights_.size();
        return 1 + 3 * m + m * m;
    }
    // Where hist_ keeps the lumped elements' count and |changes| (file_element): the bucket after the last.
    std::size_t lumped_bucket() const { return ratio_buckets * hist_stride(); }
    // Calls fn(j) for every j (an index into cond_, in filing order) the last successful remedy_elements took
    // (after an unsplit pass: a split pass keeps the further ranges' filing in parts_).
    template <class Fn>
    void for_each_taken(Fn&& fn) const {
        if (taken_cut_ == 0) return;
        for (std::size_t j = 0; j < cond_.size(); ++j)
            if ((cond_[j] & bucket_mask) < taken_cut_) fn(j);
    }

    // Two invariants (E and Z): the finishing pass accumulates the Gram sums (see remedy_elements).
    bool weights_fused() const { return weights_.size() == 2; }
    // A pass's fused sums (conditioned_pass: G_ab and A_a) in the layout the remedy solves with: G row-major,
    // max_invariants wide, A beside it; the other entries are left as they are (0).
    using gram_sums = std::array<double, max_invariants * max_invariants>;
    using invariant_sums = std::array<double, max_invariants>;
    static void gram_of(const conditioned_pass& p, gram_sums& g, invariant_sums& mag) {
        g[0] = p.g00.value(), g[1] = g[max_invariants] = p.g01.value(), g[max_invariants + 1] = p.g11.value();
        mag[0] = p.a0, mag[1] = p.a1;
    }
    void set_gram(const conditioned_pass& p) {
        g0_ = {}, mag0_ = {};
        gram_of(p, g0_, mag0_);
        gram_valid_ = true;
    }
    // The pass's sums: the Gram sums fused into it when there are two invariants.
    conditioned_pass fused_pass() const {
        conditioned_pass p;
        if (weights_fused()) p.w0 = weights_[0].data(), p.w1 = weights_[1].data();
        return p;
    }

    // Whether neg_'s conventional updates (in o) are finite.
    template <std::size_t Per>
    bool finite_updates(const double* o) const {
        for (std::size_t e : neg_) {
            double c2 = 0.0;
            for (std::size_t p = 0; p < Per; ++p) c2 += o[e * Per + p] * o[e * Per + p];
            if (!std::isfinite(c2)) return false;
        }
        return true;
    }

    // The whole state's element count and largest weights, and whether every weight is >= 0: this process's own on
    // one process, over all of them when the state is spread (set by remedy_elements).
    struct whole_state {
        std::size_t elements = 0;
        std::array<double, max_invariants> wmax{};
        bool nonnegative = true;
    };
    whole_state whole_;
    // whole_ for a state of `elements` elements: this process's own, or over every process when the state is spread,
    // summed in one collective with the caller's own sums `more` (double& or std::span<double>, summed in place).
    template <class... More>
    void set_whole(std::size_t elements, More&&... more) {
        whole_ = {elements, wmax_, weights_nonnegative_};
        if (!reduce_) return;
        double count = double(elements), negative_weights = weights_nonnegative_ ? 0.0 : 1.0;
        reduce_.sum_all(std::forward<More>(more)..., count, negative_weights);
        whole_.elements = std::size_t(count), whole_.nonnegative = negative_weights == 0.0;
        reduce_.max({whole_.wmax.data(), weights_.size()});
    }

    // The first negative radicand's real unknown after remedy_elements refused.
    template <std::size_t Per>
    std::size_t first_negative() const {
        return neg_.empty() ? 0 : neg_.front() * Per;
    }

    // The model's reductions when its state is spread over processes (set by the stepper at each step; empty
    // otherwise): try_remedy's counts and sums are then over every process, and its decisions the same on all.
    detail::reducer reduce_;
    // The model's threads for the element-wise passes (set by the stepper at each step; empty: one range).
    detail::splitter split_;

    // The conditioned update's ill-conditioned elements (see remedy_elements), in filing (element) order: each
    // (e << bucket_bits) | its bucket of xi / |change of xi| (smaller is worse). 8 bytes per element, so that on
    // turbulence (two thirds of the modes filed at CFL 0.5) the filing holds a sixth of a state, not the 88 bytes
    // per element of its values: an attempt recomputes those from the stages (conv), in filing order.
    std::vector<std::size_t> neg_;
    std::vector<double> neg_h_;  // h (below) of each element of neg_
    std::vector<std::uint64_t> cond_;
    // The filing of ranges 1, 2, ... of a split pass (range_filing); parts_used_ of them belong to the last pass.
    struct filing_part {
        std::vector<std::size_t> neg;
        std::vector<double> neg_h;
        std::vector<std::uint64_t> cond;
        std::vector<double> hist;
        bool filed = false;  // the range ran in the last pass (its histogram and lists are this pass's)
    };
    std::vector<filing_part> parts_;
    std::size_t parts_used_ = 0;
    // The filed elements' histogram over the buckets of their ratio: per bucket, its count, then for each invariant
    // a the sum of |w_ae| h_e (h = max(|x_e|^2, |c_e|^2): the element's weight in the share cap) and the sum of
    // |w_ae| (|c_e|^2 - |o_e|^2) (the change of the invariant's magnitude if taken). 32 buckets per octave of the
    // ratio from 2^-32 (below: bucket 0) to 2^31 (above: the last), from the double's exponent and first five
    // mantissa bits: equal ratios share a bucket, so mirror-image elements (a real field's k and -k on the
    // k_x = 0 column) are always taken or left together, and the state stays Hermitian.
    static constexpr std::size_t bucket_bits = 12;
    static constexpr std::uint64_t bucket_mask = (std::uint64_t(1) << bucket_bits) - 1;
    static constexpr std::size_t ratio_buckets = 64 * 32 + 1;
    static std::size_t ratio_bucket(double ratio) {
        std::uint64_t bits;
        std::memcpy(&bits, &ratio, sizeof bits);
        constexpr std::uint64_t low = std::uint64_t(1023 - 32) << 5;  // 2^-32: exponent and five mantissa bits
        const std::uint64_t top = bits >> 47;
        if (!(ratio >= 0x1p-32)) return 0;
        return std::min<std::uint64_t>(top - low + 1, ratio_buckets - 1);
    }
    // The smallest ratio in bucket b >= 1: ratio_bucket(r) >= b exactly when r >= bucket_edge(b) (for b below the
    // last bucket; ratios >= 0).
    static double bucket_edge(std::size_t b) {
        constexpr std::uint64_t low = std::uint64_t(1023 - 32) << 5;
        const std::uint64_t bits = (std::uint64_t(b) - 1 + low) << 47;
        double r;
        std::memcpy(&r, &bits, sizeof r);
        return r;
    }
    std::vector<double> hist_;

    // The first failed unknown after try_remedy declined: from its list when it made one, else by bad(i).
    template <class Bad>
    std::size_t first_failure(std::size_t n, Bad&& bad) const {
        if (!bad_.empty()) return bad_.front();
        for (std::size_t i = 0; i < n; ++i)
            if (bad(i)) return i;
        return 0;
    }

    // psi_k <- psi_k sqrt(1 + s_k), s_k = sum_j c_j w_jk, written psi_k + psi_k h_k with h = sqrt(1 + s) - 1 so that
    // a tiny s is not lost in 1 + s. For |s| <= taylor_limit = 2^-8 (the usual case: s ~ defect / invariant, 1e-8
    // or less; turbulence at CFL 0.5 rescales its largest scales by up to ~1e-3) h is its Taylor series to s^8, whose
    // remainder (< 0.011 |s|^9 / (1 - |s|), under 2^-69 h) is far below eps h: no square root, and a loop that
    // vectorizes. (To s^6 and 2^-10, as before session 45, the bench's turbulence at CFL 0.5, s up to 1.07e-3, took
    // the square root and a pass of its own to find that out.)
    // The factor h is formed once per element (a complex mode's two parts share s_k) and the loop runs over
    // elements, so that with two invariants it vectorizes: the rescale is a whole pass over the state on every
    // remedied step (most steps of turbulence), and per real unknown with the weights indexed i >> 1 it did not.
    // The operations per unknown are the ones above, so the bits are too.
    // The pass also records whether every rescaled value is finite (rescaled_), so that the engine's blow-up check
    // needs no pass of its own after it.
    static constexpr double taylor_limit = 0x1p-8;
    // h(s) = sqrt(1 + s) - 1 by its Taylor series to s^8 (binomial coefficients, exact in binary), for |s| <=
    // taylor_limit; a template so that a test can evaluate the same series in wider arithmetic.
    template <class R>
    static R h_taylor(R s) {
        return s * (R(0.5) + s * (R(-0.125) + s * (R(0.0625) + s * (R(-0.0390625) + s * (R(0.02734375) +
                    s * (R(-0.0205078125) + s * (R(0.01611328125) - s * R(0.013092041015625))))))));
    }
    template <std::size_t Per>
    void rescale(double* o, std::size_t n, const std::array<double, max_invariants>& c) {
        if (stochastic_) {
            stochastic_ = false;
            rescaled_ = rescale_stochastically<Per>(o, n, c) ? rescaled::finite : rescaled::non_finite;
            return;
        }
        const bool finite = s_bound_ <= taylor_limit
                                ? for_each_element_factor<Per>(n, c, [](double s) { return h_taylor(s); }, o)
                                : for_each_element_factor<Per>(n, c, [](double s) {
                                      return s / (1.0 + std::sqrt(1.0 + s));
                                  }, o);
        rescaled_ = finite ? rescaled::finite : rescaled::non_finite;
    }

    // Whether a rescale ran since the engine last set rescaled_ to `no` (at the start of its step), and whether it
    // left every value finite.
    enum class rescaled { no, finite, non_finite };
    rescaled rescaled_ = rescaled::no;

    // o_i += o_i h(s_e) for every real unknown i of element e, s_e = sum_j c_j w_je (element by element, so over
    // the model's threads with the same bits). Returns whether every new o_i is finite.
    template <std::size_t Per, class H>
    bool for_each_element_factor(std::size_t n, const std::array<double, max_invariants>& c, H&& h, double* o) const {
        const std::size_t m = weights_.size(), ne = n / Per;
        return split_.count(ne, [&](std::size_t e0, std::size_t e1) {
            std::uint64_t bad = 0;
            if (m == 2) {  // the common case (energy and enstrophy)
                const double* w0 = weights_[0].data();
                const double* w1 = weights_[1].data();
#if ECI_DETAIL_X86_SIMD
                if (detail::cpu_has_avx2())
                    bad = factor_two_avx2<Per>(o, w0, w1, c[0], c[1], e0, e1, h);
                else
#endif
                    bad = factor_two_base<Per>(o, w0, w1, c[0], c[1], e0, e1, h);
            } else {
                for (std::size_t e = e0; e < e1; ++e) {
                    double s = 0.0;
                    for (std::size_t j = 0; j < m; ++j) s += c[j] * weights_[j][e];
                    const double f = h(s);
                    for (std::size_t p = 0; p < Per; ++p) {
                        o[e * Per + p] += o[e * Per + p] * f;
                        bad |= detail::non_finite_bit(o[e * Per + p]);
                    }
                }
            }
            return detail::none_non_finite(bad) ? 0.0 : 1.0;
        }) == 0.0;
    }

    // for_each_element_factor's loop with two invariants, over elements e0 .. e1: the OR of the new values'
    // non_finite_bit. Always inlined, so that each caller below compiles it (and h) for its own instruction set:
    // the same operations, element by element, so the same bits.
    template <std::size_t Per, class H>
    [[gnu::always_inline]] static std::uint64_t factor_two(double* o, const double* w0, const double* w1, double c0,
                                                           double c1, std::size_t e0, std::size_t e1, H& h) {
        std::uint64_t bad = 0;
        for (std::size_t e = e0; e < e1; ++e) {
            const double f = h(c0 * w0[e] + c1 * w1[e]);
            for (std::size_t p = 0; p < Per; ++p) {
                o[e * Per + p] += o[e * Per + p] * f;
                bad |= detail::non_finite_bit(o[e * Per + p]);
            }
        }
        return bad;
    }
    template <std::size_t Per, class H>
    static std::uint64_t factor_two_base(double* o, const double* w0, const double* w1, double c0, double c1,
                                         std::size_t e0, std::size_t e1, H& h) {
        return factor_two<Per>(o, w0, w1, c0, c1, e0, e1, h);
    }
#if ECI_DETAIL_X86_SIMD
    // AVX2 (no FMA: the same roundings), picked at run time: the rescale is a whole pass over the state on most steps
    // of turbulence, and its polynomial is a dozen operations per element.
    template <std::size_t Per, class H>
    __attribute__((target("avx2"))) static std::uint64_t factor_two_avx2(double* o, const double* w0, const double* w1,
                                                                        double c0, double c1, std::size_t e0,
                                                                        std::size_t e1, H& h) {
        return factor_two<Per>(o, w0, w1, c0, c1, e0, e1, h);
    }
#endif

    // rescale() of a rescale below 2^-48 (attempt_elements): o_i + o_i h(s_e) rounded stochastically
    // (add_stochastically), seeded from the rescale's coefficients, so that a rerun gives the same bits and every
    // process the same seed (c is unchanged when the state is scaled by a power of two, as the significands are).
    // h(s) = s / 2 to within s^2 / 8 < 2^-98: the Taylor series' first term.
    template <std::size_t Per>
    bool rescale_stochastically(double* o, std::size_t n, const std::array<double, max_invariants>& c) const {
        std::uint64_t seed = 0;
        for (std::size_t j = 0; j < weights_.size(); ++j) {
            std::uint64_t b;
            std::memcpy(&b, &c[j], sizeof b);
            seed = (seed ^ b) * 0x9E3779B97F4A7C15ull;
        }
        const std::size_t m = weights_.size(), ne = n / Per;
        return split_.count(ne, [&](std::size_t e0, std::size_t e1) {
            std::uint64_t bad = 0;
            for (std::size_t e = e0; e < e1; ++e) {
                double s = 0.0;
                for (std::size_t j = 0; j < m; ++j) s += c[j] * weights_[j][e];
                const double f = 0.5 * s;
                for (std::size_t p = 0; p < Per; ++p) {
                    double& v = o[e * Per + p];
                    // the key from |v|'s significand alone: a run scaled by a power of two rounds alike
                    std::uint64_t vb;
                    std::memcpy(&vb, &v, sizeof vb);
                    const std::uint64_t key = seed ^ ((vb & 0x000FFFFFFFFFFFFFull) * 0x9E3779B97F4A7C15ull) ^ (p + 1);
                    v = add_stochastically(v, v * f, key);
                    bad |= detail::non_finite_bit(v);
                }
            }
            return detail::none_non_finite(bad) ? 0.0 : 1.0;
        }) == 0.0;
    }

    // Calls fn(i, s_i) for every real unknown i, with s_i = sum_j c_j w_ji (weights per element, i >> Shift).
    template <std::size_t Shift, class Fn>
    void for_each_factor(std::size_t n, const std::array<double, max_invariants>& c, Fn&& fn) const {
        const std::size_t m = weights_.size();
        if (m == 2) {  // the common case (energy and enstrophy), as a loop the compiler vectorizes
            const double* w0 = weights_[0].data();
            const double* w1 = weights_[1].data();
            const double c0 = c[0], c1 = c[1];
            for (std::size_t i = 0; i < n; ++i) fn(i, c0 * w0[i >> Shift] + c1 * w1[i >> Shift]);
            return;
        }
        for (std::size_t i = 0; i < n; ++i) {
            double s = 0.0;
            for (std::size_t j = 0; j < m; ++j) s += c[j] * weights_[j][i >> Shift];
            fn(i, s);
        }
    }

   private:
    template <std::size_t Per, class Conv>
    bool attempt_elements(double* o, const double* x, std::size_t n, Conv& conv, std::size_t cut,
                          std::size_t ncond) {
        const std::size_t m = weights_.size();
        constexpr std::size_t M = max_invariants;
        std::array<double, max_invariants> defect{}, held{};
        // G and A of the state with these elements conventional: the finished state's (g0_, mag0_, where neg_
        // already hold their conventional value) corrected by each changed element's w_a w_b (|c|^2 - |o|^2).
        // The corrections are small against G's entries: summed apart and added once, so that none is lost in
        // rounding against the large entries (see finish_conditioned on why G must be accurate).
        std::array<double, M * M> g = g0_, dg{};
        std::array<double, max_invariants> mag = mag0_;
        std::size_t taken = neg_.size();
        // neg_ given their conventional update: each element's defect d and share weight h (|o_e|^2 is unchanged:
        // few elements, the update recomputed, o holds it already)
        bool neg_finite = true;
        for (std::size_t e : neg_) {
            std::array<double, Per> c{};
            const auto u = conv(e, c);
            if (!std::isfinite(u.c2) || !std::isfinite(u.xi)) {
                neg_finite = false;
                break;
            }
            double x2 = 0.0;
            for (std::size_t p = 0; p < Per; ++p) o[e * Per + p] = c[p], x2 += x[e * Per + p] * x[e * Per + p];
            const double d = u.c2 - u.xi, h = std::max(x2, u.c2);
            for (std::size_t a = 0; a < m; ++a) defect[a] += weights_[a][e] * d, held[a] += std::abs(weights_[a][e]) * h;
        }
        if (reduce_) {  // over every process
            double count = double(taken), non_finite = neg_finite ? 0.0 : 1.0;
            reduce_.sum_all(count, non_finite, std::span(defect.data(), m), std::span(held.data(), m));
            taken = std::size_t(count), neg_finite = non_finite == 0.0;
        }
        if (!neg_finite) return false;
        // The ill-conditioned elements below the cut take their conventional update (written into o by settle_filed,
        // recomputed from the stages: the bits of the finishing pass); their sums are the histogram's, cumulated.
        settle_filed<Per>(o, conv, cut);
        if (cut > 0) {
            const double* h = hist_.data() + (cut - 1) * hist_stride();
            taken += std::size_t(h[0]);
            for (std::size_t a = 0; a < m; ++a) {
                held[a] += h[1 + a], mag[a] += h[1 + m + a], defect[a] += h[1 + 2 * m + a];
                for (std::size_t b = 0; b < m; ++b) dg[a * M + b] += h[1 + 3 * m + a * m + b];
            }
        }
        // (a refused attempt returns false: the next attempt, or the caller, settles o again)
        if (taken == 0) return true;
        for (std::size_t a = 0; a < m; ++a) {  // an element whose update overflowed refuses every set holding it
            bool finite = std::isfinite(defect[a]) && std::isfinite(held[a]) && std::isfinite(mag[a]);
            for (std::size_t b = 0; b < m; ++b) finite = finite && std::isfinite(dg[a * M + b]);
            if (!finite) return false;
        }
        for (std::size_t a = 0; a < m; ++a)
            for (std::size_t b = 0; b < m; ++b) g[a * M + b] += dg[a * M + b];
        for (std::size_t j = 0; j < m; ++j)
            if (!(held[j] <= share_ * mag[j])) return false;
        if (!rescale_exactly<Per>(o, n, g, mag, defect, ncond > 0)) return false;
        ++stats_.remedied_steps;
        stats_.components_remedied += taken * Per;
        stats_.conditioned += ncond * Per;
        taken_cut_ = cut;
        return true;
    }

    // The exact rescale psi_k^2 <- psi_k^2 (1 + s_k), s_k = sum_j c_j w_jk, with G c = -defect (G and A the Gram
    // sums and magnitudes of the state in o, over every process), if its size passes the caps (below); false if
    // refused (o unchanged). conditioned: the defect comes from square roots the update gave up (not from negative
    // radicands alone), so a rescale too small to be represented by rounding to nearest is rounded stochastically.
    // whole_ must describe the state (remedy_elements, rescale_conventional).
    template <std::size_t Per>
    bool rescale_exactly(double* o, std::size_t n, const std::array<double, max_invariants * max_invariants>& g,
                         const std::array<double, max_invariants>& mag,
                         const std::array<double, max_invariants>& defect, bool conditioned) {
        constexpr std::size_t shift = Per == 2 ? 1 : 0;
        const std::size_t m = weights_.size();
        constexpr std::size_t M = max_invariants;
        std::array<double, max_invariants> c{};
        if (!solve(g, mag, defect, c)) return false;
        const auto commit = [&](double s_bound) {  // the rescale, |s_k| <= s_bound
            s_bound_ = s_bound;
            rescale<Per>(o, n, c);
            return true;
        };
        // The size of the rescale (one pass, only in steps that rescale): the share of each invariant it moves,
        // sum_k |w_jk| xi_k |s_k| <= max_rescale A_j, and no xi_k changed by more than half. A cap on every |s_k|
        // alone would refuse the flows where it matters: on a Taylor-Green flow with a small perturbation E and Z
        // are nearly dependent on the large modes, so Z - 2E is restored by the perturbation's modes alone, ~1 % of
        // each of them per step at CFL 0.5, which moves 1e-8 of E and Z.
        // Bounds settle these checks without the pass when they are far from every threshold (the usual case:
        // |s_k| ~ the defect's share of an invariant, 1e-8 or less): |s_k| <= sum_j |c_j| max_k |w_jk|, and with
        // weights >= 0, sum_k |w_jk| xi_k |s_k| <= sum_i |c_i| G_ji. The pass's s_max is at least |s| at the
        // elements of largest weight (computed as the pass computes it), which settles that it is not below 2^-48
        // (rounded stochastically). The margins (2^-40 on |s|, 2^-20 on the sums, a bound on n) cover the roundings
        // of the pass and of the bounds,
        // so that a check passed here is one the pass would pass: the step's bits are the same either way.
        if (whole_.nonnegative && whole_.elements < (std::size_t(1) << 32)) {
            double ub = 0.0, lb = 0.0;
            for (std::size_t j = 0; j < m; ++j) ub += std::abs(c[j]) * whole_.wmax[j];
            // (a process that holds no element, spread over more processes than the state has columns, has no
            // largest weight: it adds nothing, and still takes part in the reduction)
            if (n != 0)
                for (std::size_t j = 0; j < m; ++j) lb = std::max(lb, s_at(c, wargmax_[j]));
            reduce_.max({&lb, 1});  // (spread: |s| at this process's largest weights, the largest over all)
            bool settled = ub * (1.0 + 0x1p-40) <= taylor_limit && (!conditioned || lb >= 0x1p-48);
            for (std::size_t j = 0; settled && j < m; ++j) {
                double bound = 0.0;
                for (std::size_t i = 0; i < m; ++i) bound += std::abs(c[i]) * g[j * M + i];
                settled = bound * (1.0 + 0x1p-20) <= remedy.max_rescale * mag[j];
            }
            if (settled) return commit(ub);
        }
        double s_max = 0.0;
        std::array<double, max_invariants> moved{};
        if (m == 2) {  // E and Z: a loop over the elements with the weights hoisted (q_e = |o_e|^2 once)
            const double* w0 = weights_[0].data();
            const double* w1 = weights_[1].data();
            const double c0 = c[0], c1 = c[1];
            double m0 = 0.0, m1 = 0.0;
            for (std::size_t e = 0; e < n / Per; ++e) {
                double q = 0.0;
                for (std::size_t p = 0; p < Per; ++p) q += o[e * Per + p] * o[e * Per + p];
                const double u = w0[e], v = w1[e], sk = std::abs(c0 * u + c1 * v), a = sk * q;
                s_max = std::max(s_max, sk);
                m0 += std::abs(u) * a, m1 += std::abs(v) * a;
            }
            moved[0] = m0, moved[1] = m1;
        } else {
            for_each_factor<shift>(n, c, [&](std::size_t i, double sk) {
                s_max = std::max(s_max, std::abs(sk));
                const double a = std::abs(sk) * o[i] * o[i];
                for (std::size_t j = 0; j < m; ++j) moved[j] += std::abs(weights_[j][i >> shift]) * a;
            });
        }
        if (reduce_) {
            reduce_.sum({moved.data(), m});
            reduce_.max({&s_max, 1});
        }
        if (!(s_max <= 0.5)) return false;
        for (std::size_t j = 0; j < m; ++j)
            if (!(moved[j] <= remedy.max_rescale * mag[j])) return false;
        // A rescale this small (every |s_k| < 2^-48: no amplitude would move by more than ~8-16 ulps) is not
        // represented by rounding to nearest: where o h is below half an ulp of o, o + o h rounds back to o, an error
        // of one sign in every such element, and the invariants would drift by ~eps per step (DP54 at dt = 0.005
        // on a 45-mode system: defects of 1e-16 of one sign, 15 eps sqrt(n)). Declining instead (keeping the
        // paper's values) lost the conditioned update's accuracy at every small step (C-RK4 14-48 x RK4's error
        // on the 30-mode n-wave system at dt = 1.25e-3). So each o + o h is rounded stochastically, unbiased:
        // the invariants then take a random walk of round-off size. Above 2^-48 the rounding of o + o h is a
        // fraction of the change, of either sign. (Negative radicands alone are rescaled as before.)
        stochastic_ = conditioned && s_max < 0x1p-48;
        return commit(s_max);
    }

    bool decline() {
        ++stats_.declined;
        return false;
    }

    // |s_e| = |sum_j c_j w_je| at element e, with the operations attempt_elements' pass uses for it.
    double s_at(const std::array<double, max_invariants>& c, std::size_t e) const {
        const std::size_t m = weights_.size();
        if (m == 2) return std::abs(c[0] * weights_[0][e] + c[1] * weights_[1][e]);
        double s = 0.0;
        for (std::size_t j = 0; j < m; ++j) s += c[j] * weights_[j][e];
        return std::abs(s);
    }

    template <std::size_t Shift>
    void gram(const double* o, std::size_t n, std::array<double, max_invariants * max_invariants>& g,
              std::array<double, max_invariants>& mag) const {
        const std::size_t m = weights_.size();
        if (m == 2) {  // two interleaved sets of sums break the add chains (G needs no particular summation order)
            const double* w0 = weights_[0].data();
            const double* w1 = weights_[1].data();
            std::array<double, 2> g00{}, g01{}, g11{}, a0{}, a1{};
            for (std::size_t i = 0; i < n; ++i) {
                const std::size_t l = i & 1;
                const double xi = o[i] * o[i], u = w0[i >> Shift], v = w1[i >> Shift];
                g00[l] += u * u * xi, g01[l] += u * v * xi, g11[l] += v * v * xi;
                a0[l] += std::abs(u) * xi, a1[l] += std::abs(v) * xi;
            }
            g[0] = g00[0] + g00[1], g[1] = g[max_invariants] = g01[0] + g01[1];
            g[max_invariants + 1] = g11[0] + g11[1];
            mag[0] = a0[0] + a0[1], mag[1] = a1[0] + a1[1];
            return;
        }
        for (std::size_t i = 0; i < n; ++i) {
            const double xi = o[i] * o[i];
            for (std::size_t a = 0; a < m; ++a) {
                const double wa = weights_[a][i >> Shift];
                mag[a] += std::abs(wa) * xi;
                for (std::size_t b = 0; b <= a; ++b) g[a * max_invariants + b] += wa * weights_[b][i >> Shift] * xi;
            }
        }
        for (std::size_t a = 0; a < m; ++a)
            for (std::size_t b = 0; b < a; ++b) g[b * max_invariants + a] = g[a * max_invariants + b];
    }

    // The Gram sums as gram() forms them, G with compensated sums (the conditioned update, any number of
    // invariants; see finish_conditioned in conservative_rk.hpp on why G must be accurate).
    template <std::size_t Shift>
    void gram_compensated(const double* o, std::size_t n, std::array<double, max_invariants * max_invariants>& g,
                          std::array<double, max_invariants>& mag) const {
        const std::size_t m = weights_.size();
        std::array<compensated_sum, max_invariants * max_invariants> acc{};
        for (std::size_t i = 0; i < n; ++i) {
            const double xi = o[i] * o[i];
            for (std::size_t a = 0; a < m; ++a) {
                const double wa = weights_[a][i >> Shift];
                mag[a] += std::abs(wa) * xi;
                for (std::size_t b = 0; b <= a; ++b) acc[a * max_invariants + b].add(wa * weights_[b][i >> Shift] * xi);
            }
        }
        for (std::size_t a = 0; a < m; ++a)
            for (std::size_t b = 0; b <= a; ++b)
                g[a * max_invariants + b] = g[b * max_invariants + a] = acc[a * max_invariants + b].value();
    }

    // G c = -defect in the least-squares sense on G's numerically non-zero eigenvalues (Jacobi-scaled, cyclic
    // Jacobi eigen-decomposition): exactly dependent weights (two names for one invariant) are handled, since the
    // defect lies in G's range. Accepts c only if the residual G c + defect is round-off of every invariant.
    bool solve(const std::array<double, max_invariants * max_invariants>& g,
               const std::array<double, max_invariants>& mag, const std::array<double, max_invariants>& defect,
               std::array<double, max_invariants>& c) const {
        const std::size_t m = weights_.size();
        constexpr std::size_t M = max_invariants;
        std::array<double, M> d{};
        for (std::size_t j = 0; j < m; ++j) d[j] = g[j * M + j] > 0.0 ? 1.0 / std::sqrt(g[j * M + j]) : 1.0;
        std::array<double, M * M> a{}, v{};
        for (std::size_t i = 0; i < m; ++i) {
            v[i * M + i] = 1.0;
            for (std::size_t j = 0; j < m; ++j) a[i * M + j] = d[i] * g[i * M + j] * d[j];
        }
        for (int sweep = 0; sweep < 30; ++sweep) {
            double off = 0.0;
            for (std::size_t p = 0; p < m; ++p)
                for (std::size_t q = p + 1; q < m; ++q) off += a[p * M + q] * a[p * M + q];
            if (off == 0.0) break;
            for (std::size_t p = 0; p < m; ++p)
                for (std::size_t q = p + 1; q < m; ++q) {
                    const double apq = a[p * M + q];
                    if (apq == 0.0) continue;
                    const double theta = (a[q * M + q] - a[p * M + p]) / (2.0 * apq);
                    const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
                    const double cs = 1.0 / std::sqrt(t * t + 1.0), sn = t * cs;
                    for (std::size_t k = 0; k < m; ++k) {  // A <- J^T A J, V <- V J
                        const double akp = a[k * M + p], akq = a[k * M + q];
                        a[k * M + p] = cs * akp - sn * akq, a[k * M + q] = sn * akp + cs * akq;
                    }
                    for (std::size_t k = 0; k < m; ++k) {
                        const double apk = a[p * M + k], aqk = a[q * M + k];
                        a[p * M + k] = cs * apk - sn * aqk, a[q * M + k] = sn * apk + cs * aqk;
                    }
                    for (std::size_t k = 0; k < m; ++k) {
                        const double vkp = v[k * M + p], vkq = v[k * M + q];
                        v[k * M + p] = cs * vkp - sn * vkq, v[k * M + q] = sn * vkp + cs * vkq;
                    }
                }
        }
        double lmax = 0.0;
        for (std::size_t i = 0; i < m; ++i) lmax = std::max(lmax, a[i * M + i]);
        if (!(lmax > 0.0)) return false;
        // Eigenvalues below the Jacobi method's absolute accuracy (a few eps lambda_max) are zero: dependent weights.
        const double cutoff = 64.0 * std::numeric_limits<double>::epsilon() * lmax;
        std::array<double, M> ct{};
        for (std::size_t e = 0; e < m; ++e) {
            const double lambda = a[e * M + e];
            if (!(lambda > cutoff)) continue;
            double proj = 0.0;
            for (std::size_t i = 0; i < m; ++i) proj -= v[i * M + e] * d[i] * defect[i];
            for (std::size_t i = 0; i < m; ++i) ct[i] += v[i * M + e] * proj / lambda;
        }
        for (std::size_t i = 0; i < m; ++i) c[i] = d[i] * ct[i];
        // What the rescale leaves of each defect; a few roundings of the invariant are allowed (the remedied step is
        // then conserving like any other), anything more means G could not absorb it.
        for (std::size_t i = 0; i < m; ++i) {
            double r = defect[i];
            for (std::size_t j = 0; j < m; ++j) r += g[i * M + j] * c[j];
            if (!std::isfinite(c[i]) || !(std::abs(r) <= 4.0 * std::numeric_limits<double>::epsilon() * mag[i]))
                return false;
        }
        return true;
    }

    quadratic_weights weights_;
    std::array<double, max_invariants> wmax_{};
    std::array<std::size_t, max_invariants> wargmax_{};  // an element of the largest |weight| of each invariant
    bool weights_nonnegative_ = true;
    std::vector<std::size_t> bad_;
    std::array<double, max_invariants * max_invariants> g0_{};  // Gram sums of the finished state (remedy_elements)
    std::array<double, max_invariants> mag0_{};
    bool gram_valid_ = false;  // g0_, mag0_ from this step's finishing pass
    bool stochastic_ = false;  // the rescale under way is below 2^-48: rounded stochastically (attempt_elements)
    double s_bound_ = 0.0;  // the bound on |s_k| of the rescale under way
    remedy_stats stats_{};
};

}  // namespace eci
