// A mission's ownership when servers share a store (a cluster,
// docs/cluster.md): whether this server still holds the copy it serves, the
// lease that keeps a mission with a live server, the takeover of a mission
// from another server, and the copies dropped when another server took them
// over.
#include "server/registry.h"

#include <functional>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "core/common/status_macros.h"
#include "spdlog/spdlog.h"

namespace oaipp::server {

absl::StatusOr<std::shared_ptr<Mission>> MissionRegistry::Hold(const std::string& key,
                                                               std::shared_ptr<Mission> held,
                                                               absl::string_view name) {
  if (held != nullptr) {
    // One indexed read: whether another server has claimed the mission
    // since this copy was read.
    absl::StatusOr<std::int64_t> epoch = store_->Epoch(key);
    if (epoch.ok() && *epoch == held->lease().epoch()) {
      KeepLease(*held);
      return held;
    }
    if (!epoch.ok() && epoch.status().code() != absl::StatusCode::kNotFound) {
      return epoch.status();
    }
    Drop(key, held,
         absl::UnavailableError(
             absl::StrCat("name: mission '", name, "' moved to another server; watch it again")));
    if (!epoch.ok()) return absl::NotFoundError(absl::StrCat("name: no mission '", name, "'"));
  }
  return TakeOver(key, name);
}

absl::StatusOr<std::shared_ptr<Mission>> MissionRegistry::TakeOver(const std::string& key,
                                                                   absl::string_view name) {
  std::shared_ptr<Takeover> takeover;
  bool first = false;
  {
    absl::MutexLock lock(&mu_);
    std::shared_ptr<Takeover>& slot = takeovers_in_progress_[key];
    if (slot == nullptr) {
      slot = std::make_shared<Takeover>();
      first = true;
    }
    takeover = slot;
    // A takeover holds a mission like a create does: checked before the
    // claim, so that a full server does not take a mission it cannot hold.
    if (first && static_cast<int>(missions_.size()) >= limits_.max_missions &&
        !missions_.contains(key)) {
      takeovers_in_progress_.erase(key);
      return absl::ResourceExhaustedError(
          absl::StrCat("this server holds its limit of ", limits_.max_missions,
                       " missions and cannot take over '", name, "'; retry later"));
    }
  }
  if (!first) {
    takeover->done.WaitForNotification();
    return takeover->result;
  }
  const absl::Time started = absl::Now();
  takeover->result = [&]() -> absl::StatusOr<std::shared_ptr<Mission>> {
    // A killed holder is found silent only silent_after after its last
    // heartbeat. Once it has missed two, the mission is read and rebuilt
    // meanwhile from what the store holds (its snapshot, megabytes, and the
    // records after it), and the claim then reads and replays only what was
    // written since. A live holder's missions are never read this way.
    // A mission on warm standby here (KeepStandbys) is read already.
    std::optional<ReadBack> warm;
    const std::shared_ptr<Standby> standby = TakeStandby(key);
    if (standby != nullptr) {
      absl::MutexLock lock(&standby->mu);
      if (standby->read.has_value()) warm = std::move(*standby->read);
      standby->read.reset();
      standby->taken = true;
    }
    std::future<absl::StatusOr<ReadBack>> early;
    if (absl::Status leased = AcquireLease(key, name,
                                           [&] {
                                             if (warm.has_value()) return;
                                             early = std::async(std::launch::async, [this, &key] {
                                               return Prefetch(key);
                                             });
                                           });
        !leased.ok()) {
      if (warm.has_value()) {
        // Still standing by (its holder is alive): kept for next time.
        absl::MutexLock lock(&standby->mu);
        standby->read = *std::move(warm);
        standby->taken = false;
        absl::MutexLock registry_lock(&mu_);
        standbys_.try_emplace(key, standby);
      }
      return leased;
    }
    const absl::Time leased = absl::Now();
    const bool from_standby = warm.has_value();
    absl::StatusOr<ReadBack> prefetched =
        warm.has_value() ? absl::StatusOr<ReadBack>(*std::move(warm))
        : early.valid()  ? early.get()
                         : absl::StatusOr<ReadBack>(absl::UnavailableError(""));
    const std::int64_t have_through =
        prefetched.ok() ? prefetched->mission->next_sequence() - 1 : 0;
    absl::StatusOr<StoredMission> claimed = store_->Claim(key, have_through);
    const absl::Time read = absl::Now();
    if (claimed.status().code() == absl::StatusCode::kNotFound) {
      return absl::NotFoundError(absl::StrCat("name: no mission '", name, "'"));
    }
    OAIPP_RETURN_IF_ERROR(claimed.status());
    // The claim left out what the early read has unless a later snapshot
    // was stored since; then it is a whole mission, rebuilt as usual.
    const bool continued = have_through > 0 && !claimed->snapshot.has_value();
    absl::StatusOr<std::shared_ptr<Mission>> mission = absl::UnknownError("not rebuilt");
    if (!continued) {
      mission = Rebuild(*claimed);
    } else if (absl::Status replayed = ReplayRecords(*prefetched, claimed->log); !replayed.ok()) {
      mission = replayed;
    } else {
      mission = Finish(*std::move(prefetched), *claimed);
    }
    if (!mission.ok()) {
      return absl::Status(mission.status().code(), absl::StrCat("taking over mission '", name,
                                                                "': ", mission.status().message()));
    }
    (*mission)->lease().set_renewed(leased);
    std::shared_ptr<Mission> replaced;
    {
      absl::MutexLock lock(&mu_);
      if (auto it = missions_.find(key); it != missions_.end()) replaced = it->second;
      Register(key, *mission);
      created_by_request_.Remember(claimed->request_id, {key, claimed->fingerprint});
      ++takeovers_;
      if (from_standby && continued) ++takeovers_from_standby_;
    }
    if (replaced != nullptr) {
      replaced->events().CloseAll(absl::UnavailableError(
          absl::StrCat("name: mission '", name, "' was read back; watch it again")));
    }
    // ms: the whole takeover; waiting for the lease, reading the mission
    // (the claim) and rebuilding it are its three parts.
    // read_early: whether the mission was read before the claim, while
    // waiting for the lease or ahead as a warm standby (standby) (records:
    // then those written since).
    spdlog::info(
        "mission event=taken_over name={} epoch={} read_early={} standby={} records={} "
        "ms={:.1f} lease_ms={:.1f} claim_ms={:.1f} rebuild_ms={:.1f}",
        std::string(name), claimed->epoch, continued, from_standby, claimed->log.size(),
        absl::ToDoubleMilliseconds(absl::Now() - started),
        absl::ToDoubleMilliseconds(leased - started), absl::ToDoubleMilliseconds(read - leased),
        absl::ToDoubleMilliseconds(absl::Now() - read));
    return mission;
  }();
  {
    absl::MutexLock lock(&mu_);
    takeovers_in_progress_.erase(key);
  }
  takeover->done.Notify();
  return takeover->result;
}

std::string MissionRegistry::LeaseName(const std::string& key) {
  return absl::StrCat("mission/", absl::BytesToHexString(key));
}

absl::StatusOr<MissionRegistry::ReadBack> MissionRegistry::Prefetch(const std::string& key) {
  OAIPP_ASSIGN_OR_RETURN(StoredMission stored, store_->Load(key));
  OAIPP_ASSIGN_OR_RETURN(ReadBack read, ReadBackBase(stored));
  OAIPP_RETURN_IF_ERROR(ReplayRecords(read, stored.log));
  return read;
}

absl::Status MissionRegistry::AcquireLease(const std::string& key, absl::string_view name,
                                           const std::function<void()>& holder_failing) {
  const absl::Time deadline = absl::Now() + limits_.silent_after;
  bool told = false;
  while (true) {
    const absl::Time now = absl::Now();
    absl::StatusOr<bool> held =
        store_->TryLease(LeaseName(key), limits_.holder, absl::ToUnixMicros(now),
                         absl::ToUnixMicros(now + limits_.mission_lease), true);
    OAIPP_RETURN_IF_ERROR(held.status());
    if (*held) return absl::OkStatus();
    if (!told) {
      // A live holder says "alive for silent_after" every silent_after / 5,
      // so what is left of its time stays above 4/5 of it; below 3/5 it has
      // missed two heartbeats.
      const absl::StatusOr<std::int64_t> alive_until =
          store_->LeaseHolderAliveUntil(LeaseName(key));
      if (alive_until.ok() &&
          absl::FromUnixMicros(*alive_until) - now < limits_.silent_after * 3 / 5) {
        told = true;
        holder_failing();
      }
    }
    // Another server holds it and was alive when asked: a holder that just
    // died is found silent within silent_after, so a short wait here saves
    // the caller a retry; a live holder keeps its mission.
    if (now >= deadline) {
      return absl::UnavailableError(absl::StrCat(
          "name: mission '", name,
          "' is served by another server, which is alive; this call reached the wrong one "
          "(its x-oaipp-mission header names another mission, or the routing is changing); "
          "nothing was applied; retry"));
    }
    absl::SleepFor(std::min(absl::Milliseconds(50), deadline - now));
  }
}

void MissionRegistry::KeepLease(Mission& mission) {
  const absl::Time now = absl::Now();
  if (now - mission.lease().renewed() < limits_.mission_lease / 4) return;
  mission.lease().set_renewed(now);
  const std::string& key = mission.id();
  // Renewed only while it is this server's (or free): had it lapsed and
  // been taken, the taker's claim fences this copy's next write.
  const absl::StatusOr<bool> held =
      store_->TryLease(LeaseName(key), limits_.holder, absl::ToUnixMicros(now),
                       absl::ToUnixMicros(now + limits_.mission_lease), false);
  if (!held.ok()) {
    spdlog::warn("lease of mission 'missions/{}': {}", std::string(PublicId(key)),
                 held.status().ToString());
  }
}

void MissionRegistry::Drop(const std::string& key, const std::shared_ptr<Mission>& mission,
                           const absl::Status& reason) {
  {
    absl::MutexLock lock(&mu_);
    auto it = missions_.find(key);
    if (it == missions_.end() || it->second != mission) return;
    missions_.erase(it);
    order_.erase(number_of_[key]);
    number_of_.erase(key);
  }
  spdlog::info(
      "mission event=dropped name=missions/{} reason=\"another server took it over or deleted it\"",
      std::string(PublicId(key)));
  mission->events().CloseAll(reason);
}

absl::Status MissionRegistry::AfterFailedWrite(const std::shared_ptr<Mission>& mission,
                                               absl::Status status) {
  if (status.ok()) return status;
  const std::string name = MissionName(mission->id());
  if (status.GetPayload(kFenced).has_value()) {
    absl::Status moved = absl::UnavailableError(absl::StrCat(
        "name: mission '", name, "' is now served by another server; nothing was applied; retry"));
    Drop(mission->id(), mission, moved);
    return moved;
  }
  if (status.GetPayload(kInDoubt).has_value()) {
    if (absl::Status reloaded = Reload(mission->id()); !reloaded.ok()) {
      spdlog::warn("store: {}", reloaded.ToString());
    } else {
      spdlog::info("store: mission '{}' read back after a write in doubt", mission->id());
    }
  }
  return status;
}

std::vector<std::string> MissionRegistry::DropMoved() {
  std::vector<std::string> dropped;
  if (!limits_.shared_store) return dropped;
  for (const std::shared_ptr<Mission>& m : List(0, static_cast<std::size_t>(-1))) {
    absl::StatusOr<std::int64_t> epoch = store_->Epoch(m->id());
    if (epoch.ok() && *epoch == m->lease().epoch()) continue;
    if (!epoch.ok() && epoch.status().code() != absl::StatusCode::kNotFound) break;  // store down
    Drop(m->id(), m,
         absl::UnavailableError(absl::StrCat("name: mission 'missions/", PublicId(m->id()),
                                             "' moved to another server; watch it again")));
    dropped.push_back(m->id());
  }
  return dropped;
}

std::int64_t MissionRegistry::takeovers() const {
  absl::MutexLock lock(&mu_);
  return takeovers_;
}

}  // namespace oaipp::server
