#include "tsf/crms/solver.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "effects_engine.h"
#include "solver_backend.h"
#include "tsf/common/cuda_support.h"
#include "tsf/common/error.h"
#include "tsf/crms/crms_math.h"
#include "tsf/crms/effect_energy.h"
#include "tsf/crms/effect_stable_step.h"
#include "tsf/crms/effects.h"
#include "tsf/crms/implicit_euler.h"
#include "tsf/crms/node_energy.h"
#include "tsf/crms/stencil.h"

namespace tsf::crms {

std::string Instability::describe() const {
  char text[512];
  std::snprintf(text, sizeof text,
                "non-finite state at step %lld: node %lld (%d,%d,%d), rest (%.4g, %.4g, %.4g) mm, "
                "last finite position (%.4g, %.4g, %.4g) mm; the solver halted there",
                static_cast<long long>(step), static_cast<long long>(node), coordinates.x,
                coordinates.y, coordinates.z, rest_position_mm.x, rest_position_mm.y,
                rest_position_mm.z, position_mm.x, position_mm.y, position_mm.z);
  return text;
}

Solver::Solver(Lattice lattice, const SolverConfig& config)
    : lattice_(std::move(lattice)), config_(config) {
  validate_solver_config(config_);
  lattice_.validate();
  const LatticeGeometry& g = lattice_.geometry();
  for (std::int64_t n = 0; n < lattice_.node_count(); ++n)
    for (int c = 0; c < 4; ++c) {
      const MaterialBlend b = lattice_.material(n);
      // The message is built only on failure: building it for every node took ~10 s at 256³.
      if (b.weight_of(c) != 0u && static_cast<std::size_t>(b.entry(c)) >= config_.materials.size())
        throw Error("lattice node " + std::to_string(n) + " uses material " +
                    std::to_string(b.entry(c)) + " but only " +
                    std::to_string(config_.materials.size()) + " material(s) are configured");
    }

  const bool symmetric = config_.angular_reactions == AngularReactions::kSymmetric;
  palette_.count = static_cast<int>(config_.materials.size());
  for (int m = 0; m < palette_.count; ++m)
    palette_.entry[m] = calibrate_springs(config_.materials[m], g.spacing, symmetric);
  if (config_.effects.animation.enabled)
    timeline_ = AnimationTimeline(config_.effects.animation, lattice_,
                                  static_cast<int>(config_.materials.size()), palette_.count);
  stable_ = stable_time_step_with_effects(lattice_, palette_, config_);
  require_compiled_feature_set(features());

  Backend backend = config_.backend;
  if (config_.integrator == Integrator::kImplicitEuler) backend = Backend::kCpu;
  if (backend == Backend::kAuto) backend = cuda_status().available ? Backend::kCuda : Backend::kCpu;
  if (backend == Backend::kCuda) {
    require(cuda_status().available,
            "backend cuda requested but CUDA is not usable here: " + cuda_status().reason);
    backend_ = make_cuda_backend(g, backend_options(config_));
    on_cuda_ = true;
  } else {
    backend_ = make_cpu_backend(g, backend_options(config_));
  }

  std::vector<float> inv_mass(static_cast<std::size_t>(lattice_.node_count()), 0.0f);
  for (std::int64_t n = 0; n < lattice_.node_count(); ++n)
    if (lattice_.alive(n)) inv_mass[n] = 1.0f / lattice_.mass(n);
  std::vector<MaterialBlend> material;
  if (palette_.count > 1) {
    material.resize(static_cast<std::size_t>(lattice_.node_count()));
    for (std::int64_t n = 0; n < lattice_.node_count(); ++n) material[n] = lattice_.material(n);
  }
  backend_->upload_lattice(lattice_.packed_flags(), inv_mass, material);

  if (config_.effects.plasticity.enabled) effect_bits_ |= effect_bits::kPlasticity;
  if (config_.effects.anisotropy.enabled) effect_bits_ |= effect_bits::kAnisotropy;
  if (config_.effects.fluid.enabled) effect_bits_ |= effect_bits::kFluid;
  if (config_.effects.tearing.enabled) effect_bits_ |= effect_bits::kTearing;
  if (config_.effects.tearing.enabled && config_.effects.tearing.node_force_threshold_un > 0)
    effect_bits_ |= effect_bits::kNodeMasking;
  const std::vector<RestOffsets>& keyframes = timeline_.rest_offsets();
  if (!keyframes.empty()) effect_bits_ |= effect_bits::kRestAnimation;
  for (const Material& m : config_.materials)
    if (m.poisson_ratio > 0.0) effect_bits_ |= effect_bits::kVolumetric;
  // Implicit Euler takes the volumetric term into its own Newton system (implicit_euler.h); the
  // other effects are explicit only (validate_solver_config).
  if (effect_bits_ != 0 && config_.integrator != Integrator::kImplicitEuler)
    effects_ = on_cuda_ ? make_cuda_effects(g, effect_bits_, keyframes, backend_->native_stream())
                        : make_cpu_effects(g, effect_bits_, keyframes);
}

MaterialUpdate Solver::backend_material_update() {
  return [this](const std::vector<std::int64_t>& nodes, const std::vector<MaterialBlend>& blends) {
    backend_->update_materials(nodes, blends);
  };
}

BackendOptions backend_options(const SolverConfig& config) {
  BackendOptions o;
  o.evaluation = config.force_evaluation;
  o.cpu_instruction_set = config.cpu_instruction_set;
  o.cpu_tile_rows = config.cpu_tile_rows;
  o.cuda_steps_per_graph = config.cuda_steps_per_graph;
  o.cuda_planes_per_block = config.cuda_planes_per_block;
  o.cuda_tile_rows = config.cuda_tile_rows;
  o.cuda_launch = config.cuda_launch;
  o.cuda_tile_kernel = config.cuda_tile_kernel;
  o.cuda_fold_volume_term = config.cuda_fold_volume_term;
  return o;
}

Solver::~Solver() = default;

std::string Solver::backend_name() const {
  return backend_->name();
}

unsigned Solver::features() const {
  unsigned f = 0;
  if (config_.angular_form == AngularForm::kCosine) f |= features::kCosineAngular;
  if (config_.angular_reactions == AngularReactions::kSymmetric) f |= features::kSymmetricReactions;
  if (external_forces_) f |= features::kExternalForces;
  if (palette_.count > 1) f |= features::kHeterogeneous;
  return f;
}

double Solver::stable_dt() const {
  return config_.integrator == Integrator::kExplicitEuler ? stable_.explicit_euler_s
                                                          : stable_.symplectic_euler_s;
}

double Solver::velocity_limit_mm_s(double dt) const {
  return step_parameters(dt).velocity_limit;
}

StepParameters Solver::step_parameters(double dt) const {
  StepParameters p;
  p.dt = static_cast<float>(dt);
  p.gravity = to_float(config_.gravity);
  p.kinetic_damping = static_cast<float>(config_.stability.kinetic_damping);
  double limit = config_.stability.velocity_limit;
  if (limit < 0.0)
    limit = config_.stability.velocity_limit_auto_fraction * lattice_.geometry().min_spacing() / dt;
  p.velocity_limit = static_cast<float>(limit);
  p.scheme = static_cast<int>(config_.integrator == Integrator::kExplicitEuler
                                  ? ExplicitScheme::kExplicitEuler
                                  : ExplicitScheme::kSymplecticEuler);
  p.palette = palette_;
  return p;
}

StepReport Solver::step(int n, double dt) {
  const std::int64_t before = steps_done_;
  if (config_.integrator == Integrator::kImplicitEuler) {
    validate_time_step(dt);
    require(n >= 0, "step count must not be negative");
    StepReport report;
    if (!instability_) step_implicit(n, dt, report);
    report.steps_run = steps_done_ - before;
    report.instability = instability_;
    return report;
  }
  step_async(n, dt);
  StepReport report = synchronize();
  report.steps_run = steps_done_ - before;
  return report;
}

void Solver::step_async(int n, double dt) {
  validate_time_step(dt);
  require(n >= 0, "step count must not be negative");
  require(config_.integrator != Integrator::kImplicitEuler,
          "step_async: implicit Euler steps synchronously, use step()");
  if (instability_ || n == 0) return;
  if (timeline_.has_material_tracks())
    timeline_.apply_material_tracks(time_s_, lattice_, backend_material_update());
  if (effects_) {
    step_with_effects(n, dt);
  } else {
    backend_->step(n, step_parameters(dt), features());
  }
  steps_done_ += n;
  time_s_ += n * dt;
  backend_->poll_snapshot();
}

StepReport Solver::step_measured(int n, double dt, bool with_velocities, StepSignals& signals) {
  signals = StepSignals{};
  signals.velocities = with_velocities;
  const double k_sys = config_.stability.kinetic_damping;
  // On CUDA the signals are summed on the device; with effects only where the effects' energy is
  // too, else the host measurement below copies the state out every call.
  if (on_cuda_ && config_.integrator != Integrator::kImplicitEuler &&
      (!effects_ || effects_energy_on_device()) && backend_->has_step_signals()) {
    // One host wait for the whole call: the steps, the volumetric term's energy, the guard and
    // the signals are queued on the one stream and read back together (before: a wait for the
    // steps' guard, one for the sums and one for the term's energy).
    const std::int64_t before = steps_done_;
    const bool stepping = !instability_ && n > 0;
    step_async(n, dt);
    const bool term_queued =
        effects_energy_on_device() &&
        effects_->queue_volume_energy(backend_->lattice_view(), backend_->state_view(),
                                      effect_parameters(1.0));
    const StepParameters p = step_parameters(dt);
    EnergySums sums;
    // v0 is the other state buffer: the state before the last step, if there was one.
    const bool have_v0 = with_velocities && stepping;
    std::optional<GuardHit> hit;
    backend_->step_signals(p, features(), have_v0, k_sys, sums, signals.velocity, &hit);
    backend_->poll_snapshot();
    if (hit && !instability_) {
      instability_ = make_instability(hit->node, hit->step);
      steps_done_ = hit->step + 1;
    }
    StepReport report;
    report.instability = instability_;
    report.steps_run = steps_done_ - before;
    signals.energy.kinetic_nj = sums.kinetic;
    signals.energy.elastic_nj =
        sums.elastic + (term_queued ? effects_->queued_volume_energy() : effects_energy_nj());
    signals.energy.gravitational_nj = sums.gravitational;
    signals.energy.load_nj = load_energy_nj();
    if (with_velocities && !have_v0) {  // nothing stepped: no v0, no period-2 products
      const std::vector<Vec3f> v = velocities();
      measure_velocities(v, v, dt, signals.velocity);
      signals.velocity.v0v1 = signals.velocity.v0v0 = 0;
    }
    return report;
  }
  // Host measurement: the last step alone, the velocities copied before and after it.
  StepReport report;
  std::vector<Vec3f> v0;
  if (!with_velocities) {
    report = step(n, dt);
  } else {
    if (n > 1) report = step(n - 1, dt);
    if (!report.instability) {
      v0 = velocities();
      const StepReport last = step(1, dt);
      report.steps_run += last.steps_run;
      report.instability = last.instability;
    }
  }
  signals.energy = energy();
  if (with_velocities) {
    const std::vector<Vec3f> v1 = velocities();
    measure_velocities(v0.empty() ? v1 : v0, v1, dt, signals.velocity);
    if (v0.empty()) signals.velocity.v0v1 = signals.velocity.v0v0 = 0;
  }
  return report;
}

void Solver::measure_velocities(const std::vector<Vec3f>& v0, const std::vector<Vec3f>& v1,
                                double dt, VelocitySignals& s) const {
  const double limit = velocity_limit_mm_s(dt);
  const double k_sys = config_.stability.kinetic_damping;
  for (std::int64_t i = 0; i < lattice_.node_count(); ++i)
    add_velocity_signals(lattice_.packed_flags(i), lattice_.mass(i), to_double(v0[i]),
                         to_double(v1[i]), limit, k_sys, s);
}

EffectParameters Solver::effect_parameters(double dt) const {
  const EffectsConfig& e = config_.effects;
  EffectParameters p;
  p.enabled = effect_bits_;
  p.dt = static_cast<float>(dt);
  p.symplectic = config_.integrator != Integrator::kExplicitEuler;
  p.velocity_limit = static_cast<float>(velocity_limit_mm_s(dt));
  p.heterogeneous = palette_.count > 1;
  p.palette = palette_;
  p.yield_strain = static_cast<float>(e.plasticity.yield_strain);
  p.creep_step = static_cast<float>(std::min(e.plasticity.creep_rate * dt, 1.0));
  p.recovery_decay = static_cast<float>(std::exp(-e.plasticity.recovery_rate * dt));
  const Vec3d a = e.anisotropy.axis;
  const double a2 = a.x * a.x + a.y * a.y + a.z * a.z;
  for (int ax = 0; ax < 3; ++ax)
    p.aniso_extra[ax] =
        static_cast<float>((e.anisotropy.stiffness_factor - 1.0) * a[ax] * a[ax] / a2);
  p.bulk_modulus = static_cast<float>(e.fluid.bulk_modulus_pa);
  p.diffusion_step = static_cast<float>(-std::expm1(-6.0 * e.fluid.diffusion_rate * dt) / 6.0);
  p.tear_strain = static_cast<float>(e.tearing.strain_threshold);
  p.node_force_limit = static_cast<float>(e.tearing.node_force_threshold_un);
  if (p.heterogeneous)  // per-material tear strains and anisotropy (calibration.h)
    for (int m = 0; m < palette_.count; ++m) {
      const Material& mat = config_.materials[static_cast<std::size_t>(m)];
      p.material_tear_strain[m] =
          static_cast<float>(mat.tear_strain > 0.0 ? mat.tear_strain : e.tearing.strain_threshold);
      const bool own = mat.anisotropy_factor > 0.0;
      const Vec3d axis = own ? mat.anisotropy_axis : e.anisotropy.axis;
      const double factor = own ? mat.anisotropy_factor : e.anisotropy.stiffness_factor;
      const double len2 = axis.x * axis.x + axis.y * axis.y + axis.z * axis.z;
      for (int ax = 0; ax < 3; ++ax)
        p.material_aniso_extra[ax][m] =
            len2 > 0.0 ? static_cast<float>((factor - 1.0) * axis[ax] * axis[ax] / len2) : 0.0f;
    }
  p.volume = volume_parameters();
  timeline_.set_time(p, time_s_);
  return p;
}

VolumeParameters Solver::volume_parameters() const {
  return calibrate_volume(config_.materials);
}

void Solver::step_with_effects(int n, double dt) {
  // Folded where the backend can (below); otherwise one core step at a time between the effect
  // passes. The guard is checked every step on the CPU (free) and every 64 steps on CUDA (a host
  // wait): after a hit the effect passes stop and the backend, halted, leaves the state as it was.
  const StepParameters p = step_parameters(dt);
  if (volume_term_folded()) {
    // The volumetric term alone, folded into the backend's launch: the same passes in the same
    // order inside every step, one launch for the n steps (docs/crms.md, "The product path with
    // the volumetric term").
    FoldedVolumeTerm volume;
    volume.parameters = volume_parameters();
    if (float* const* terms = effects_->volume_term_arrays())
      for (int c = 0; c < 9; ++c) volume.terms[c] = terms[c];
    backend_->step_folded(n, p, features(), volume);
    return;
  }
  EffectParameters e = effect_parameters(dt);
  const int check_every = on_cuda_ ? 64 : 1;
  int s = 0;
  for (; s < n; ++s) {
    timeline_.set_time(e, time_s_ + s * dt);
    effects_->before_step(backend_->lattice_view(), backend_->state_view(), e);
    backend_->step(1, p, features());
    effects_->after_step(backend_->lattice_view(), backend_->state_view(), e);
    if ((s + 1) % check_every == 0 && backend_->synchronize()) {
      ++s;
      break;
    }
  }
  if (s < n) backend_->step(n - s, p, features());  // halted: advances the count only
}

bool Solver::volume_term_folded() const {
  return effects_ && effect_bits_ == static_cast<unsigned>(effect_bits::kVolumetric) &&
         backend_->folds_volume_term(features());
}

std::vector<std::string> Solver::active_effects() const {
  std::vector<std::string> names = config_.effects.active();
  if (effect_bits_ & effect_bits::kVolumetric) names.emplace_back("volumetric");
  return names;
}

EffectsState Solver::effects_state() const {
  if (!effects_) return {};
  return effects_->read();
}

std::int64_t Solver::torn_springs() const {
  if ((effect_bits_ & effect_bits::kTearing) == 0) return 0;
  const std::vector<std::uint8_t> flags = effects_->read_flags(backend_->lattice_view());
  std::int64_t torn = torn_synced_;
  for (std::int64_t n = 0; n < lattice_.node_count(); ++n)
    for (int ax = 0; ax < 3; ++ax) {
      const int d = make_direction(ax, 1);
      if (lattice_.link(n, d) && ((flags[n] >> d) & 1u) == 0) ++torn;
    }
  return torn;
}

void Solver::sync_torn_links() {
  const std::vector<std::uint8_t> flags = effects_->read_flags(backend_->lattice_view());
  std::vector<std::int64_t> touched;
  for (std::int64_t n = 0; n < lattice_.node_count(); ++n)
    for (int ax = 0; ax < 3; ++ax) {
      const int d = make_direction(ax, 1);
      if (lattice_.link(n, d) && ((flags[n] >> d) & 1u) == 0) {
        lattice_.break_spring(n, d);
        ++torn_synced_;
        torn_pending_.push_back({n, d});
        touched.push_back(n);
        touched.push_back(lattice_.neighbour(n, d));
      }
    }
  // A tear severs like a cut: the cut triggers watching these nodes fire.
  if (!touched.empty() && timeline_.has_cut_triggers()) {
    std::sort(touched.begin(), touched.end());
    timeline_.fire_cut_triggers(touched, lattice_, backend_material_update());
  }
}

std::vector<SpringRef> Solver::take_torn_springs() {
  if ((effect_bits_ & effect_bits::kTearing) == 0) return {};
  sync_torn_links();
  std::vector<SpringRef> torn;
  torn.swap(torn_pending_);
  return torn;
}

std::size_t Solver::raise_event(const std::string& event) {
  if (!timeline_.has_cut_triggers()) return 0;
  return timeline_.fire_event_triggers(event, lattice_, backend_material_update());
}

bool Solver::effects_energy_on_device() const {
  // The volumetric term alone (the term the shipped soft tissue runs with); implicit Euler keeps
  // the term in its own Newton system and has no effects engine.
  return on_cuda_ && effects_ && effect_bits_ == static_cast<unsigned>(effect_bits::kVolumetric);
}

double Solver::effects_energy_nj() const {
  if ((effect_bits_ &
       (effect_bits::kSpringEffects | effect_bits::kFluid | effect_bits::kVolumetric)) == 0)
    return 0.0;
  if (effects_energy_on_device())
    return *effects_->volume_energy_here(backend_->lattice_view(), backend_->state_view(),
                                         effect_parameters(1.0));
  EffectEnergyInputs in;
  backend_->read_state(&in.displacement_mm, nullptr);
  in.flags = (effect_bits_ & effect_bits::kTearing) ? effects_->read_flags(backend_->lattice_view())
                                                    : lattice_.packed_flags();
  in.material.resize(static_cast<std::size_t>(lattice_.node_count()));
  for (std::int64_t n = 0; n < lattice_.node_count(); ++n) in.material[n] = lattice_.material(n);
  if (effects_) in.effects = effects_->read();
  return effects_elastic_energy_nj(lattice_.geometry(), in, effect_parameters(1.0),
                                   timeline_.rest_offsets(), config_.effects.fluid.bulk_modulus_pa);
}

StepReport Solver::synchronize() {
  StepReport report;
  const std::optional<GuardHit> hit = backend_->synchronize();
  backend_->poll_snapshot();
  if (hit && !instability_) {
    instability_ = make_instability(hit->node, hit->step);
    steps_done_ = hit->step + 1;
  }
  report.instability = instability_;
  return report;
}

void Solver::clear_instability() {
  ++edits_;
  instability_.reset();
  backend_->reset_guard();
}

void Solver::step_implicit(int n, double dt, StepReport& report) {
  (void)report;
  const StepParameters p = step_parameters(dt);
  const VolumeParameters volume = volume_parameters();
  for (int s = 0; s < n; ++s) {
    const ImplicitStepStats stats =
        implicit_euler_step(backend_->lattice_view(), backend_->state_view(), p, features(),
                            config_.implicit_newton_iterations, config_.implicit_tolerance,
                            (effect_bits_ & effect_bits::kVolumetric) ? &volume : nullptr);
    if (stats.first_non_finite_node >= 0) {
      instability_ = make_instability(stats.first_non_finite_node, steps_done_);
      ++steps_done_;
      return;
    }
    ++steps_done_;
    time_s_ += dt;
  }
}

Instability Solver::make_instability(std::int64_t node, std::int64_t step) const {
  Instability s;
  s.step = step;
  s.node = node;
  const LatticeGeometry& g = lattice_.geometry();
  s.coordinates = g.coordinates(node);
  s.rest_position_mm = g.rest_position(node);
  std::vector<Vec3f> u, v;
  backend_->read_state(&u, &v);
  s.position_mm = s.rest_position_mm + to_double(u[node]);
  s.velocity_mm_s = to_double(v[node]);
  return s;
}

void Solver::set_gravity(const Vec3d& gravity) {
  ++edits_;
  SolverConfig c = config_;
  c.gravity = gravity;
  validate_solver_config(c);
  config_.gravity = gravity;
}

void Solver::set_external_forces(const std::vector<std::int64_t>& nodes,
                                 const std::vector<Vec3f>& forces) {
  ++edits_;
  require(nodes.size() == forces.size(), "set_external_forces: nodes and forces differ in size");
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    require(nodes[i] >= 0 && nodes[i] < lattice_.node_count(),
            "set_external_forces: node " + std::to_string(nodes[i]) + " is out of range");
    require(crms_finite(forces[i]),
            "set_external_forces: force on node " + std::to_string(nodes[i]) + " is not finite");
  }
  if (!external_forces_) {
    require_compiled_feature_set(features() | features::kExternalForces);
    backend_->enable_external_forces();
    external_forces_ = true;
    external_host_.assign(static_cast<std::size_t>(lattice_.node_count()), Vec3f{0, 0, 0});
  }
  backend_->set_external_forces(nodes, forces);
  for (std::size_t i = 0; i < nodes.size(); ++i) external_host_[nodes[i]] = forces[i];
}

void Solver::clear_external_forces() {
  ++edits_;
  if (!external_forces_) return;
  backend_->clear_external_forces();
  std::fill(external_host_.begin(), external_host_.end(), Vec3f{0, 0, 0});
}

void Solver::constrain_nodes(const std::vector<std::int64_t>& nodes,
                             const std::vector<Vec3d>& targets) {
  release_and_constrain({}, nodes, targets);
}

void Solver::release_nodes(const std::vector<std::int64_t>& nodes) {
  ++edits_;
  for (std::int64_t n : nodes) {
    require(n >= 0 && n < lattice_.node_count(),
            "release_nodes: node " + std::to_string(n) + " is out of range");
    lattice_.set_fixed(n, false);
  }
  refresh_flags(nodes);
}

void Solver::release_and_constrain(const std::vector<std::int64_t>& release,
                                   const std::vector<std::int64_t>& hold,
                                   const std::vector<Vec3d>& targets) {
  require(hold.size() == targets.size(), "constrain_nodes: nodes and targets differ in size");
  if (release.empty() && hold.empty()) return;
  for (std::int64_t n : release)
    require(n >= 0 && n < lattice_.node_count(),
            "release_nodes: node " + std::to_string(n) + " is out of range");
  std::vector<Vec3f> u(hold.size()), v(hold.size());
  for (std::size_t i = 0; i < hold.size(); ++i) {
    require(hold[i] >= 0 && hold[i] < lattice_.node_count(),
            "constrain_nodes: node " + std::to_string(hold[i]) + " is out of range");
    require(
        std::isfinite(targets[i].x) && std::isfinite(targets[i].y) && std::isfinite(targets[i].z),
        "constrain_nodes: target of node " + std::to_string(hold[i]) + " is not finite");
    u[i] = to_float(targets[i] - lattice_.geometry().rest_position(hold[i]));
  }
  ++edits_;
  // Released first, then held: a node in both ends up held, as with the two calls in that order.
  for (std::int64_t n : release) lattice_.set_fixed(n, false);
  for (std::int64_t n : hold) lattice_.set_fixed(n, true);
  std::vector<std::int64_t> touched;
  touched.reserve(release.size() + hold.size());
  touched.insert(touched.end(), release.begin(), release.end());
  touched.insert(touched.end(), hold.begin(), hold.end());
  std::vector<std::int64_t> list;
  std::vector<std::uint8_t> flags;
  flag_update(touched, list, flags);
  // One edit of the backend: on CUDA the flags and the held nodes' states are queued on the
  // solver's stream and waited for once.
  backend_->update_flags_and_write_nodes(list, flags, hold, u, v);
}

void Solver::set_node_states(const std::vector<std::int64_t>& nodes,
                             const std::vector<Vec3d>& positions,
                             const std::vector<Vec3f>& velocities) {
  ++edits_;
  require(nodes.size() == positions.size() && nodes.size() == velocities.size(),
          "set_node_states: nodes, positions and velocities differ in size");
  std::vector<Vec3f> u(nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    require(nodes[i] >= 0 && nodes[i] < lattice_.node_count(),
            "set_node_states: node " + std::to_string(nodes[i]) + " is out of range");
    u[i] = to_float(positions[i] - lattice_.geometry().rest_position(nodes[i]));
  }
  backend_->write_nodes(nodes, u, velocities);
}

void Solver::set_state(const std::vector<Vec3f>& displacements,
                       const std::vector<Vec3f>& velocities) {
  ++edits_;
  const auto count = static_cast<std::size_t>(lattice_.node_count());
  require(displacements.size() == count && velocities.size() == count,
          "set_state: expected " + std::to_string(count) + " displacements and velocities");
  for (std::size_t n = 0; n < count; ++n)
    require(crms_finite(displacements[n]) && crms_finite(velocities[n]),
            "set_state: node " + std::to_string(n) + " has a non-finite state");
  backend_->write_state(displacements, velocities);
}

void Solver::delete_nodes(const std::vector<std::int64_t>& nodes) {
  ++edits_;
  for (std::int64_t n : nodes) {
    require(n >= 0 && n < lattice_.node_count(),
            "delete_nodes: node " + std::to_string(n) + " is out of range");
    lattice_.set_alive(n, false);
  }
  refresh_flags(nodes);
  if (timeline_.has_cut_triggers())
    timeline_.fire_cut_triggers(nodes, lattice_, backend_material_update());
}

void Solver::break_springs(const std::vector<SpringRef>& springs) {
  ++edits_;
  std::vector<std::int64_t> touched;
  for (const SpringRef& s : springs) {
    require(s.node >= 0 && s.node < lattice_.node_count() && s.direction >= 0 &&
                s.direction < kFaceDirections,
            "break_springs: spring (" + std::to_string(s.node) + ", " +
                std::to_string(s.direction) + ") is out of range");
    lattice_.break_spring(s.node, s.direction);
    touched.push_back(s.node);
    const std::int64_t other = lattice_.neighbour(s.node, s.direction);
    if (other >= 0) touched.push_back(other);
  }
  refresh_flags(touched);
  if (timeline_.has_cut_triggers())
    timeline_.fire_cut_triggers(touched, lattice_, backend_material_update());
}

void Solver::refresh_flags(const std::vector<std::int64_t>& nodes) {
  std::vector<std::int64_t> list;
  std::vector<std::uint8_t> flags;
  flag_update(nodes, list, flags);
  backend_->update_flags(list, flags);
}

void Solver::flag_update(const std::vector<std::int64_t>& nodes, std::vector<std::int64_t>& list,
                         std::vector<std::uint8_t>& flags) {
  // Tearing cleared links on the backend only: bring them to the host lattice first so that
  // the flags uploaded below do not restore them.
  if (effect_bits_ & effect_bits::kTearing) sync_torn_links();
  // The nodes and their neighbours, each once, ascending. Few of them (a tool contact's dozens)
  // are sorted; many (a cut's ~3,600 touched nodes name ~100 k with repeats; a std::set of them
  // took 1.2 ms) are marked and read off the marked range, which spans whole lattice planes.
  list.clear();
  list.reserve(nodes.size() * (kFaceDirections + 1));
  std::int64_t lo = lattice_.node_count(), hi = -1;
  for (std::int64_t n : nodes) {
    list.push_back(n);
    for (int d = 0; d < kFaceDirections; ++d) {
      const std::int64_t m = lattice_.neighbour(n, d);
      if (m >= 0) list.push_back(m);
    }
  }
  for (std::int64_t n : list) {
    lo = std::min(lo, n);
    hi = std::max(hi, n);
  }
  if (static_cast<std::int64_t>(list.size()) * 64 < hi - lo) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  } else {
    flag_marks_.resize(static_cast<std::size_t>(lattice_.node_count()), 0);
    for (std::int64_t n : list) flag_marks_[static_cast<std::size_t>(n)] = 1;
    list.clear();
    for (std::int64_t n = lo; n <= hi; ++n)
      if (flag_marks_[static_cast<std::size_t>(n)]) {
        flag_marks_[static_cast<std::size_t>(n)] = 0;
        list.push_back(n);
      }
  }
  flags.resize(list.size());
  for (std::size_t i = 0; i < list.size(); ++i) flags[i] = lattice_.packed_flags(list[i]);
}

std::vector<Vec3f> Solver::positions() const {
  std::vector<Vec3f> u;
  backend_->read_state(&u, nullptr);
  const LatticeGeometry& g = lattice_.geometry();
  for (std::int64_t n = 0; n < lattice_.node_count(); ++n) {
    const Int3 c = g.coordinates(n);
    u[n] = node_position(g.origin, g.spacing, c.x, c.y, c.z, u[n]);
  }
  return u;
}

std::vector<Vec3f> Solver::displacements() const {
  std::vector<Vec3f> u;
  backend_->read_state(&u, nullptr);
  return u;
}

std::vector<Vec3f> Solver::velocities() const {
  std::vector<Vec3f> v;
  backend_->read_state(nullptr, &v);
  return v;
}

EnergyReport Solver::energy() const {
  const EnergySums s = backend_->energy(step_parameters(1.0), features());
  EnergyReport r;
  r.kinetic_nj = s.kinetic;
  r.elastic_nj = s.elastic + effects_energy_nj();
  r.gravitational_nj = s.gravitational;
  r.load_nj = load_energy_nj();
  return r;
}

double Solver::load_energy_nj() const {
  if (!external_forces_) return 0.0;
  // Constant loads: potential −Σ F·u (µN·mm = nJ).
  std::vector<Vec3f> u;
  backend_->read_state(&u, nullptr);
  double e = 0.0;
  for (std::int64_t n = 0; n < lattice_.node_count(); ++n)
    if (lattice_.alive(n)) e -= static_cast<double>(dot(external_host_[n], u[n]));
  return e;
}

std::vector<Vec3f> Solver::spring_forces() const {
  std::vector<Vec3f> forces;
  backend_->spring_forces(step_parameters(1.0), features(), forces);
  return forces;
}

LatticeView Solver::lattice_view() const {
  return backend_->lattice_view();
}
StateView Solver::state_view() const {
  return backend_->state_view();
}

void Solver::request_snapshot() {
  backend_->request_snapshot(steps_done_);
}
void Solver::poll_snapshot() {
  backend_->poll_snapshot();
}
const SnapshotBuffer& Solver::snapshots() const {
  return backend_->snapshots();
}

double Solver::bytes_per_node() const {
  return backend_->bytes_per_node() + (effects_ ? effects_->bytes_per_node() : 0.0);
}

}  // namespace tsf::crms
